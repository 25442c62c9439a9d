#!/usr/bin/python3
"""Plot an E3 (postures) run of an arm or both arms: `peha run --config configs/right_arm.yaml --experiment postures`.

Reads RUN_DIR/e3_postures.csv and RUN_DIR/summary.csv (one row per posture and judged joint) and writes
RUN_DIR/plot.png:
  top:    the judged joints' angles over time (measured and plant), the operator's grips shaded,
          the releases marked, and the torques (gravity model, operator) below;
  bottom: the drift after each release, zoomed: angle minus angle at release, per posture.
Run with Debian's /usr/bin/python3 (numpy + matplotlib).
"""
import argparse
import csv
import io
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.stderr.write("plot_arm.py: needs numpy and matplotlib: run it with /usr/bin/python3\n")
    sys.exit(1)


def read(path):
    with open(path) as f:
        text = "".join(line for line in f if not line.startswith("#"))
    return np.genfromtxt(io.StringIO(text), delimiter=",", names=True, dtype=None, encoding=None)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dir", help="run folder written by peha run --experiment postures")
    p.add_argument("--out", help="output PNG (default RUN_DIR/plot.png)")
    a = p.parse_args()
    log_path = os.path.join(a.run_dir, "e3_postures.csv")
    if not os.path.exists(log_path):
        sys.stderr.write(f"plot_arm.py: {log_path} not found\n")
        return 2
    d = read(log_path)
    rows = np.atleast_1d(read(os.path.join(a.run_dir, "summary.csv")))
    joints = list(dict.fromkeys(str(j) for j in rows["joint"]))
    postures = list(dict.fromkeys(str(p) for p in rows["posture"]))
    # Log column prefix: "sfe" for a single arm's R_SFE, "r_sfe" when both arms are logged.
    two_sides = len({j.split("_", 1)[0] for j in joints}) > 1
    prefix = {j: (j if two_sides else j.split("_", 1)[1]).lower() for j in joints}
    colour = {j: f"C{i}" for i, j in enumerate(joints)}
    def target(posture):
        return ", ".join(f"{float(r['target_deg']):.0f}" for r in rows if str(r["posture"]) == posture)
    s = rows[[str(j) == joints[0] for j in rows["joint"]]]  # one row per posture
    t = d["t_s"]
    op = d["operator_active"] > 0.5
    releases = t[1:][(op[:-1]) & (~op[1:])]
    # The first grip only holds the arm while compensation starts; the postures' releases follow.
    releases = releases[-len(s):] if len(releases) > len(s) else releases

    fig = plt.figure(figsize=(14, 10))
    ax1 = fig.add_subplot(3, 1, 1)
    ax2 = fig.add_subplot(3, 1, 2, sharex=ax1)
    edges = np.flatnonzero(np.diff(np.r_[0, op.astype(int), 0]))
    for ax in (ax1, ax2):
        for x0, x1 in zip(edges[::2], edges[1::2]):
            ax.axvspan(t[x0], t[x1 - 1], color="0.88", lw=0)
        for r in releases:
            ax.axvline(r, color="0.4", ls=":", lw=0.8)
    for name in joints:
        j, c = prefix[name], colour[name]
        ax1.plot(t, np.degrees(d[f"{j}_plant_angle_rad"]), c, lw=1.2, label=f"{name} (plant)")
        ax1.plot(t, np.degrees(d[f"{j}_angle_rad"]), c, lw=0.6, ls="--", label=f"{name} (encoder)")
        ax2.plot(t, d[f"{j}_tau_gravity_Nm"], c, lw=1.0, label=f"{name} J$^T$G")
        ax2.plot(t, d[f"{j}_operator_torque_Nm"], c, lw=0.6, ls=":", label=f"{name} operator")
    ax1.set_ylabel("joint angle [deg]")
    ax1.set_title("E3: the operator carries the arm to each posture (grey) and lets go (dotted)")
    ax1.legend(loc="upper right", fontsize=8, ncol=2)
    ax2.set_ylabel("torque [Nm]")
    ax2.set_xlabel("time [s]")
    ax2.legend(loc="upper right", fontsize=8, ncol=2)

    names = s.dtype.names or ()
    limit = float(s["max_drift_deg"][0]) if "max_drift_deg" in names and len(s) else None
    if "within_limits" in names and len(s):
        ok = int(s["within_limits"][0]) == 1
        fig.suptitle("verdict %s: |drift| <= %.2g deg (red dashed), lowest wire tension %.1f N (floor %.1f N)"
                     % ("OK" if ok else "FAILED", limit, float(s["min_wire_tension_N"][0]),
                        float(s["min_wire_tension_limit_N"][0])), color="black" if ok else "red", fontsize=11)

    n = len(releases)
    for i, r in enumerate(releases):
        ax = fig.add_subplot(3, max(n, 1), 2 * max(n, 1) + i + 1)
        m = (t >= r) & (t <= r + 10.0)
        k0 = np.argmax(t >= r)
        for joint in joints:
            j = prefix[joint]
            ax.plot(t[m] - r, np.degrees(d[f"{j}_plant_angle_rad"][m] - d[f"{j}_plant_angle_rad"][k0]), colour[joint], lw=1.0, label=joint)
        name = postures[i] if i < len(postures) else f"#{i + 1}"
        ax.set_title(f"{name}\n({target(name)}) deg" if i < len(postures) else name, fontsize=9)
        ax.set_xlabel("time after release [s]", fontsize=8)
        if i == 0:
            ax.set_ylabel("drift [deg]")
            ax.legend(fontsize=7)
        ax.axhline(0, color="k", lw=0.5)
        if limit is not None:  # the verdict's drift threshold (summary.csv max_drift_deg)
            for sign in (-1, 1):
                ax.axhline(sign * limit, color="red", ls="--", lw=0.8)
            lo, hi = ax.get_ylim()
            ax.set_ylim(min(lo, -1.2 * limit), max(hi, 1.2 * limit))
        else:
            ax.set_ylim(-0.5, 0.5)
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    out = a.out or os.path.join(a.run_dir, "plot.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
