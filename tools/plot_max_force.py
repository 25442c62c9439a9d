#!/usr/bin/python3
"""Plot the logs of an E5 run (`peha run --config configs/e5_max_force.yaml`): the maximum-force test.

One column per log e5_<case>.csv, two rows sharing the time axis:
  1. the ramped muscle's force [N]: load cell (and the plant's truth where logged), the force
     ceiling as a horizontal line, the at-limit band from summary.csv shaded;
  2. pressures [MPa]: the ramp's requested pressure, the command the limits sent, the limits'
     pressure ceiling and the measured pressure of the ramped muscle.
Writes plot.png into RUN_DIR. Needs numpy + matplotlib (Debian: /usr/bin/python3).
Exit codes: 0 success, 1 unreadable log, 2 bad RUN_DIR or no logs.
"""

import argparse
import csv
import glob
import os
import sys


def read_log(path):
    with open(path) as f:
        lines = [line for line in f if not line.startswith("#")]
    rows = list(csv.reader(lines))
    header, data = rows[0], rows[1:]
    return {name: [float(r[i]) for r in data] for i, name in enumerate(header)}


def read_summary(run_dir):
    path = os.path.join(run_dir, "summary.csv")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return {row["case"]: row for row in csv.DictReader(f)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run_dir")
    parser.add_argument("--title", default="E5 maximum-force ramp")
    args = parser.parse_args(argv)
    logs = sorted(glob.glob(os.path.join(args.run_dir, "e5_*.csv")))
    if not os.path.isdir(args.run_dir) or not logs:
        print(f"error: no e5_*.csv logs in {args.run_dir}", file=sys.stderr)
        return 2
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = read_summary(args.run_dir)
    fig, axes = plt.subplots(2, len(logs), figsize=(5.5 * len(logs), 7), sharex="col", squeeze=False)
    for col, path in enumerate(logs):
        case = os.path.basename(path)[3:-4]
        try:
            d = read_log(path)
        except (OSError, ValueError, IndexError) as e:
            print(f"error: {path}: {e}", file=sys.stderr)
            return 1
        s = summary.get(case, {})
        muscle = s.get("muscle", "agonist")
        t = d["t_s"]
        limit = d["force_limit_N"][0]
        ax = axes[0][col]
        ax.plot(t, d[f"{muscle}_loadcell_N"], color="C0", lw=1.2, label=f"{muscle} load cell")
        truth = d.get(f"plant_{muscle}_force_N")
        if truth and any(v == v for v in truth):
            ax.plot(t, truth, color="k", lw=0.8, ls="--", label="plant force (truth)")
        ax.axhline(limit, color="C3", lw=1.2, label=f"force ceiling {limit:.0f} N")
        if "at_limit_band_N" in s:
            band = float(s["at_limit_band_N"])
            ax.axhspan(limit - band, limit + band, color="C3", alpha=0.12, label=f"at the limit (+-{band:.0f} N)")
        verdict = "" if not s else (" - OK" if s.get("passed") == "1" else " - FAIL")
        head = f"{case}{verdict}"
        if s:
            head += f"\npeak {float(s['peak_force_N']):.1f} N, overshoot {float(s['overshoot_N']):.1f} N, at limit {float(s['time_at_limit_s']):.2f} s"
        ax.set_title(head, fontsize=9)
        ax.set_ylabel("force [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
        ax = axes[1][col]
        ax.plot(t, d["ramp_pressure_cmd_MPa"], color="0.5", lw=1.0, ls=":", label="ramp (requested)")
        ax.plot(t, d[f"{muscle}_pressure_cmd_MPa"], color="C0", lw=1.2, ls="--", label="command sent (limited)")
        ax.plot(t, d["ceiling_pressure_MPa"], color="C3", lw=1.0, label="limits' pressure ceiling")
        ax.plot(t, d[f"{muscle}_pressure_MPa"], color="C0", lw=1.0, label="measured")
        top = max(d["ceiling_pressure_MPa"] + d[f"{muscle}_pressure_MPa"]) * 1.15
        ax.set_ylim(0, top)
        ax.set_ylabel(f"{muscle} pressure [MPa]")
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(args.title)
    fig.tight_layout()
    out = os.path.join(args.run_dir, "plot.png")
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
