#!/usr/bin/python3
"""Plot a `peha run` of the wire-creep experiment (docs/creep.md): RUN_DIR/creep_<run>.csv.

One column per (plant variant, force-trim rate); three rows sharing the time axis [min]:
  1. wire length change [mm]: plant truth (black) and estimate +- 2 sigma (colour), both wires,
     the alert threshold and the alert instants;
  2. force-tracking error [N]: RMS(request - load cell) per sample, agonist, estimator off / on;
  3. static torque error [% of gravity] after each release, estimator off / on.
Writes RUN_DIR/creep.png. Must run on an interpreter with numpy + matplotlib (/usr/bin/python3).
Exit codes: 0 success, 2 bad RUN_DIR or no logs.
"""

import argparse
import csv
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in (rows[0].keys() if rows else [])}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--alert-mm", type=float, default=1.0)
    args = ap.parse_args()
    if not os.path.isdir(args.run_dir):
        print(f"error: {args.run_dir} is not a directory", file=sys.stderr)
        return 2
    runs = {}
    for name in sorted(os.listdir(args.run_dir)):
        m = re.fullmatch(r"creep_(.+)_trim([0-9.]+)_(on|off)\.csv", name)
        if m:
            runs.setdefault((m.group(1), m.group(2)), {})[m.group(3)] = name
    if not runs:
        print(f"error: no creep_<run>.csv in {args.run_dir}", file=sys.stderr)
        return 2
    keys = sorted(runs, key=lambda k: (k[0] != "nominal", k[0], -float(k[1])))
    fig, axes = plt.subplots(3, len(keys), figsize=(5.2 * len(keys), 9.5), sharex=True, squeeze=False)
    for col, key in enumerate(keys):
        variant, trim = key
        pair = runs[key]
        ax = axes[0][col]
        ax.set_title(f"{variant}, trim {trim}/s" + (" (pure feed-forward)" if float(trim) == 0 else ""), fontsize=9)
        if "on" in pair:
            d = read_csv(os.path.join(args.run_dir, pair["on"]))
            t = [x / 60 for x in d["t_s"]]
            for i, (w, c) in enumerate((("agonist", "C0"), ("antagonist", "C1"))):
                est, sig = d[f"estimate_{w}_mm"], d[f"sigma_{w}_mm"]
                ax.plot(t, d[f"truth_{w}_mm"], color="k", lw=1.0, ls="-" if i == 0 else "--",
                        label=f"{w} truth" if col == 0 else None)
                ax.plot(t, est, color=c, lw=1.2, label=f"{w} estimate" if col == 0 else None)
                ax.fill_between(t, [e - 2 * s for e, s in zip(est, sig)], [e + 2 * s for e, s in zip(est, sig)],
                                color=c, alpha=0.2, lw=0)
                bit = 1 << i
                first = next((tt for tt, a in zip(t, d["alerts"]) if int(a) & bit), None)
                if first is not None:
                    ax.axvline(first, color=c, lw=0.8, ls=":")
            ax.axhline(args.alert_mm, color="r", lw=0.7, ls=":", label="alert threshold" if col == 0 else None)
        ax.set_ylabel("wire length change [mm]")
        ax.grid(alpha=0.3)
        ax = axes[1][col]
        for state, c in (("off", "C3"), ("on", "C2")):
            if state in pair:
                d = read_csv(os.path.join(args.run_dir, pair[state]))
                ax.plot([x / 60 for x in d["t_s"]], d["tracking_rms_agonist_N"], color=c, lw=0.8,
                        label=f"agonist, estimator {state}")
        ax.set_ylabel("force tracking RMS [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax = axes[2][col]
        for state, c in (("off", "C3"), ("on", "C2")):
            path = os.path.join(args.run_dir, f"releases_{variant}_trim{trim}_{state}.csv")
            if os.path.exists(path):
                d = read_csv(path)
                if d:
                    ax.plot([x / 60 for x in d["release_time_s"]], d["static_torque_error_pct"], ".", color=c, ms=3,
                            label=f"estimator {state}")
        ax.set_ylabel("static torque error [% gravity]")
        ax.set_xlabel("time [min]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Wire creep: estimate vs plant truth, force tracking and static torque error, estimator off / on")
    fig.tight_layout()
    out = os.path.join(args.run_dir, "creep.png")
    fig.savefig(out, dpi=110)
    print(f"written: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
