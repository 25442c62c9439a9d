#!/usr/bin/python3
"""Plot an E4 (goniometer-driven elbow) run: `peha run --config configs/right_arm.yaml --experiment goniometer`.

Reads RUN_DIR/summary.csv and RUN_DIR/e4_<movement>_<variant>.csv and writes RUN_DIR/plot.png, one
column per movement and, for every driven joint (summary.csv's `joint`: R_EFE; R_EFE and L_EFE on the
upper body), three rows:
  top:    the person's joint (truth), the goniometer's reading, and the exoskeleton's joint with the
          paper's pure inverse-dynamics replay (open_loop) and with the impedance added (feedback);
  middle: tracking error exo - person of both variants;
  bottom: the joint's torque commands (inverse dynamics; + impedance).
With one driven joint the log's columns are person_elbow_deg, ...; with several each starts with the
joint's log name (r_efe_person_elbow_deg on two arms, efe_... on one).
Run with Debian's /usr/bin/python3 (numpy + matplotlib).
"""
import argparse
import io
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.stderr.write("plot_goniometer.py: needs numpy and matplotlib: run it with /usr/bin/python3\n")
    sys.exit(1)


def read(path):
    with open(path) as f:
        text = "".join(line for line in f if not line.startswith("#"))
    return np.genfromtxt(io.StringIO(text), delimiter=",", names=True, dtype=None, encoding=None)


def column(d, joint, name):
    """The log column `name` of driven joint `joint`: prefixed by its log name when there is one."""
    low = joint.lower()
    for prefix in (low + "_", low.split("_", 1)[-1] + "_", ""):
        if prefix + name in d.dtype.names:
            return d[prefix + name]
    raise KeyError(f"no column {name} for {joint}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dir", help="run folder written by peha run --experiment goniometer")
    p.add_argument("--out", help="output PNG (default RUN_DIR/plot.png)")
    a = p.parse_args()
    summary_path = os.path.join(a.run_dir, "summary.csv")
    if not os.path.exists(summary_path):
        sys.stderr.write(f"plot_goniometer.py: {summary_path} not found\n")
        return 2
    s = np.atleast_1d(read(summary_path))
    movements = list(dict.fromkeys(str(m) for m in s["movement"]))
    joints = list(dict.fromkeys(str(j) for j in s["joint"])) if "joint" in s.dtype.names else ["R_EFE"]
    rows = 3 * len(joints)
    fig, axes = plt.subplots(rows, len(movements), figsize=(7 * len(movements), 10 * len(joints)), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 1.5, 1.5] * len(joints)})
    colors = {"open_loop": "tab:red", "feedback": "tab:blue"}
    for c, m in enumerate(movements):
        for n, joint in enumerate(joints):
            ax, ax_e, ax_t = axes[3 * n][c], axes[3 * n + 1][c], axes[3 * n + 2][c]
            first = True
            mine = s[s["movement"] == m]
            if "joint" in s.dtype.names:
                mine = mine[mine["joint"] == joint]
            for row in mine:
                v = str(row["variant"])
                d = read(os.path.join(a.run_dir, f"e4_{m}_{v}.csv"))
                t = d["t_s"]
                if first:
                    ax.plot(t, column(d, joint, "goniometer_deg"), color="0.7", lw=0.6, label="goniometer (200 Hz, noisy)")
                    ax.plot(t, column(d, joint, "person_elbow_deg"), color="k", lw=1.4, label=f"person's {joint}")
                    op = d["operator_active"] > 0.5
                    if op.any():
                        for a_ in (ax, ax_e, ax_t):
                            a_.axvspan(t[op][0], t[op][-1], color="0.92", lw=0)
                    first = False
                label = "pure ID replay (paper)" if v == "open_loop" else "ID + impedance"
                exo = column(d, joint, "plant_elbow_deg")
                ax.plot(t, exo, color=colors.get(v, "tab:green"), lw=1.1,
                        label=f"exo {joint}, {label}: RMS {row['rms_error_deg']:.1f} deg, delay {row['delay_ms']:.0f} ms"
                        + (f", verdict {'OK' if int(row['within_limits']) == 1 else 'FAIL'}" if "within_limits" in s.dtype.names else ""))
                ax_e.plot(t, exo - column(d, joint, "person_elbow_deg"), color=colors.get(v, "tab:green"), lw=0.9, label=v)
                ax_t.plot(t, column(d, joint, "tau_elbow_cmd_Nm"), color=colors.get(v, "tab:green"), lw=0.7, label=f"{joint} torque cmd, {v}")
            ax.set_title(f"E4 movement '{m}', {joint}")
            ax.set_ylabel(f"{joint} angle (deg)")
            ax.legend(fontsize=8, loc="upper right")
            ax.grid(alpha=0.3)
            ax_e.set_ylabel("exo - person (deg)")
            ax_e.axhline(0, color="k", lw=0.5)
            ax_e.grid(alpha=0.3)
            ax_e.legend(fontsize=8)
            ax_t.set_ylabel("torque (Nm)")
            ax_t.set_xlabel("time (s); grey: the operator holds the arm")
            ax_t.grid(alpha=0.3)
            ax_t.legend(fontsize=8, loc="upper right")
    title = "E4: goniometer -> Butterworth -> derivatives -> inverse dynamics -> torque of " + ", ".join(joints)
    if "max_tracking_rms_deg" in s.dtype.names:  # the verdict's tracking thresholds (summary.csv)
        title += "\nverdict: tracking RMS <= %.3g deg, max <= %.3g deg, wire tension >= %.3g N" % (
            float(s["max_tracking_rms_deg"][0]), float(s["max_tracking_error_deg"][0]), float(s["min_wire_tension_limit_N"][0]))
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.05 / len(joints)))  # room for the two-line title
    out = a.out or os.path.join(a.run_dir, "plot.png")
    fig.savefig(out, dpi=110)
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
