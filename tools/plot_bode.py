#!/usr/bin/python3
"""Bode plot of an E6 run (`peha run --config configs/right_arm.yaml --experiment bandwidth`).

Reads RUN_DIR/bode.csv (variant, frequency_Hz, gain, gain_dB, phase_deg and, when present,
gain_at_joint_dB, phase_at_joint_deg) and writes RUN_DIR/bode.png: magnitude (dB) and phase (deg) of
delivered / desired joint torque for each variant (PAM-only, hybrid), solid as the actuator produces
it (muscle-side tensions + motor), dashed at the joint after the cables; with the -3 dB line and each
variant's -3 dB frequency marked. Run with /usr/bin/python3.
"""
import argparse
import csv
import os
import sys

try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.stderr.write("plot_bode.py: needs numpy and matplotlib: run it with /usr/bin/python3\n")
    sys.exit(1)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dir")
    p.add_argument("--out", help="output PNG (default RUN_DIR/bode.png)")
    a = p.parse_args()
    path = os.path.join(a.run_dir, "bode.csv")
    if not os.path.exists(path):
        sys.stderr.write(f"plot_bode.py: {path} not found\n")
        return 2
    rows = list(csv.DictReader(open(path)))
    fig, (ax_m, ax_p) = plt.subplots(2, 1, figsize=(9, 8), sharex=True)
    for variant, colour in (("pam_only", "C0"), ("hybrid", "C3")):
        r = [x for x in rows if x["variant"] == variant]
        if not r:
            continue
        f = np.array([float(x["frequency_Hz"]) for x in r])
        g = np.array([float(x["gain_dB"]) for x in r])
        ph = np.array([float(x["phase_deg"]) for x in r])
        label = "PAM only" if variant == "pam_only" else "hybrid (PAMs + motor)"
        ax_m.semilogx(f, g, "o-", color=colour, label=label + ", actuator")
        ax_p.semilogx(f, ph, "o-", color=colour, label=label + ", actuator")
        if "gain_at_joint_dB" in r[0]:
            gj = np.array([max(float(x["gain_at_joint_dB"]), -60.0) for x in r])  # -inf at zero gain
            pj = np.array([float(x["phase_at_joint_deg"]) for x in r])
            ax_m.semilogx(f, gj, "s--", color=colour, alpha=0.7, label=label + ", at the joint after the cables")
            ax_p.semilogx(f, pj, "s--", color=colour, alpha=0.7, label=label + ", at the joint after the cables")
        lin = np.array([float(x["gain"]) for x in r])
        threshold = 1.0 / np.sqrt(2.0)
        below = np.flatnonzero(lin < threshold)
        if below.size and below[0] > 0:
            # Same rule as peha (experiments::run_bandwidth): linear gain, interpolated in log frequency.
            i = below[0]
            w = (lin[i - 1] - threshold) / (lin[i - 1] - lin[i])
            f3 = np.exp(np.log(f[i - 1]) + w * (np.log(f[i]) - np.log(f[i - 1])))
            ax_m.axvline(f3, color=colour, ls=":", lw=1)
            ax_m.annotate(f"{f3:.2f} Hz", (f3, -3.0103), color=colour, textcoords="offset points", xytext=(5, 8))
    ax_m.axhline(-3.0103, color="k", ls="--", lw=0.8, label="-3 dB")
    ax_m.set_ylabel("|delivered / desired torque| [dB]")
    ax_m.set_title("E6: joint torque bandwidth, arm locked (torque bench)")
    ax_m.legend()
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_xlabel("frequency [Hz]")
    ax_p.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    out = a.out or os.path.join(a.run_dir, "bode.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
