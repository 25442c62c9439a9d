#!/usr/bin/env python3
"""Heat map of a robustness matrix (peha robustness, docs/robustness.md).

Reads RUN_DIR/robustness.csv and writes RUN_DIR/heatmap.png: one row per plant variant, one column
per mode x payload (seeds: the worst). Left: |static torque error| in % of the gravity torque (E3:
no truth figure, its worst |drift| in deg is shown instead, hatched); right: lowest wire tension as a
fraction of the pretension. Each cell is annotated with its value and the verdict (x = failed);
a red frame marks a missed goal. E4's rows (mode e4_goniometer) are left out: their figures are
tracking, not static, and robustness.md tables them. Run with /usr/bin/python3 (numpy, matplotlib).
"""
import argparse
import csv
import math
import os
import sys


def read(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def num(text):
    try:
        return float(text)
    except ValueError:
        return float("nan")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--out", help="PNG to write (default RUN_DIR/heatmap.png)")
    a = p.parse_args(argv)
    path = os.path.join(a.run_dir, "robustness.csv")
    if not os.path.isfile(path):
        sys.stderr.write("plot_robustness.py: %s not found\n" % path)
        return 2
    # E4's rows have no static torque error: their table is in robustness.md, not in this map.
    rows = [r for r in read(path) if r["mode"] != "e4_goniometer"]
    if not rows:
        sys.stderr.write("plot_robustness.py: %s has no rows\n" % path)
        return 2
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.patches import Rectangle

    variants = list(dict.fromkeys(r["variant"] for r in rows))
    columns = list(dict.fromkeys((r["mode"], r["payload"]) for r in rows))
    shape = (len(variants), len(columns))
    err, frac = np.full(shape, np.nan), np.full(shape, np.nan)
    verdict, goal, drift_only = np.ones(shape, bool), np.ones(shape, bool), np.zeros(shape, bool)
    for r in rows:
        i, j = variants.index(r["variant"]), columns.index((r["mode"], r["payload"]))
        e = num(r["static_torque_error_pct"])
        if math.isnan(e):
            e, drift_only[i, j] = num(r["drift_deg"]), True
        err[i, j] = np.nanmax([err[i, j], e])
        frac[i, j] = np.nanmin([frac[i, j], num(r["tension_fraction"])])
        verdict[i, j] &= r["verdict"] == "1"
        goal[i, j] &= r["goal"] == "1"

    fig, axes = plt.subplots(1, 2, figsize=(4 + 1.6 * len(columns) * 2, 1.2 + 0.42 * len(variants)))
    labels = ["%s\n%s" % (m.replace("_", " "), pl) for m, pl in columns]
    panels = [(axes[0], err, "|static torque error| % of gravity\n(E3: |drift| deg, hatched)", "magma_r", (0, 20)),
              (axes[1], frac, "lowest wire tension / pretension", "viridis", (0, 1.2))]
    for ax, data, title, cmap, (lo, hi) in panels:
        im = ax.imshow(np.clip(data, lo, hi), cmap=cmap, vmin=lo, vmax=hi, aspect="auto")
        ax.set_xticks(range(len(columns)), labels, fontsize=8)
        ax.set_yticks(range(len(variants)), variants, fontsize=8)
        ax.set_title(title, fontsize=10)
        fig.colorbar(im, ax=ax, fraction=0.04)
        for i in range(shape[0]):
            for j in range(shape[1]):
                v = data[i, j]
                text = ("%.1f" % v if v < 100 else "%.0f" % v) if not math.isnan(v) else "-"
                if not verdict[i, j]:
                    text += " x"
                shade = (np.clip(v, lo, hi) - lo) / (hi - lo) if not math.isnan(v) else 0
                dark = shade > 0.55 if cmap == "magma_r" else shade < 0.45
                ax.text(j, i, text, ha="center", va="center", fontsize=7, color="white" if dark else "black")
                if ax is axes[0] and drift_only[i, j]:
                    ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="///", lw=0, alpha=0.3))
                if not goal[i, j]:
                    ax.add_patch(Rectangle((j - 0.48, i - 0.48), 0.96, 0.96, fill=False, ec="red", lw=1.2))
    fig.suptitle("peha robustness: %s   (x = verdict failed, red frame = goal missed)" %
                 os.path.basename(os.path.normpath(os.path.abspath(a.run_dir))), fontsize=11)
    fig.tight_layout()
    out = a.out or os.path.join(a.run_dir, "heatmap.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
