#!/usr/bin/env python3
"""Margins per check of a false-alarm run (peha false-alarms, docs/safety.md "False alarms").

Reads RUN_DIR/false_alarms.csv and writes RUN_DIR/margins.png: one row per plausibility check, one
bar per sensor-noise scale (x1 includes the plant variants): the largest ratio of the quantity the
check compares with its threshold over the runs (log scale), the 99th percentile as a tick. The line
at 1 is the threshold (a trip), the dashed one 1/1.5 (the margin the verdict asks at x1). Checks that
compared nothing are left out. Run with /usr/bin/python3 (numpy, matplotlib).
"""
import argparse
import csv
import os
import sys


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--out", help="PNG to write (default RUN_DIR/margins.png)")
    p.add_argument("--margin", type=float, default=1.5, help="the margin goal drawn (default 1.5)")
    a = p.parse_args(argv)
    path = os.path.join(a.run_dir, "false_alarms.csv")
    if not os.path.isfile(path):
        sys.stderr.write("plot_false_alarms.py: %s not found\n" % path)
        return 2
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        sys.stderr.write("plot_false_alarms.py: %s has no rows\n" % path)
        return 2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fixed = {"case", "variant", "noise_scale", "seed", "duration_s", "flags", "first_flag"}
    checks = [c for c in rows[0].keys() if c not in fixed]
    scales = sorted({float(r["noise_scale"]) for r in rows})
    stats = {}
    for s in scales:
        for c in checks:
            v = np.array([float(r[c]) for r in rows if float(r["noise_scale"]) == s])
            v = v[v > 0]
            if v.size:
                stats[(s, c)] = (v.max(), np.percentile(v, 99))
    shown = [c for c in checks if any((s, c) in stats for s in scales)]
    fig, ax = plt.subplots(figsize=(9, 0.45 * len(shown) * len(scales) / 2 + 2))
    h = 0.8 / len(scales)
    colors = plt.cm.viridis(np.linspace(0.15, 0.85, len(scales)))
    for k, s in enumerate(scales):
        ys = [i + (k - (len(scales) - 1) / 2) * h for i in range(len(shown))]
        mx = [stats.get((s, c), (np.nan, np.nan))[0] for c in shown]
        p99 = [stats.get((s, c), (np.nan, np.nan))[1] for c in shown]
        ax.barh(ys, mx, height=h, color=colors[k], label="noise x%g%s" % (s, " + variants" if s == 1 else ""))
        ax.plot(p99, ys, "|", color="k", markersize=8)
    ax.axvline(1.0, color="r", lw=1.5, label="threshold (trip)")
    ax.axvline(1.0 / a.margin, color="r", lw=1, ls="--", label="threshold / %g" % a.margin)
    ax.set_xscale("log")
    ax.set_xlim(1e-3, max(2.0, max(v[0] for v in stats.values()) * 1.3))
    ax.set_yticks(range(len(shown)))
    ax.set_yticklabels(shown)
    ax.invert_yaxis()
    ax.set_xlabel("largest ratio to the threshold over the fault-free runs (| : 99th percentile)")
    ax.set_title("Plausibility checks on fault-free runs: %d runs" % len(rows))
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(True, axis="x", which="both", alpha=0.3)
    fig.tight_layout()
    out = a.out or os.path.join(a.run_dir, "margins.png")
    fig.savefig(out, dpi=120)
    print("wrote %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
