#!/usr/bin/python3
"""Plot the report of `peha calibrate` (run with Debian's /usr/bin/python3: numpy + matplotlib).

Reads REPORT_DIR/predictions.csv (and spgp_grid.csv, pseudo_inputs.csv, summary.txt when present)
and writes REPORT_DIR/report.png with four panels:
  1. measured pressure and the models' pressures over time (held-out blocks shaded), like Fig. 8;
  2. the data in (contraction, force), coloured by pressure;
  3. the pressure residual before and after the SPGP (held-out blocks shaded);
  4. the SPGP's predictive standard deviation over (contraction, force) with the data and the
     pseudo-inputs: where it is large, the calibration data did not reach.
With operating_points.csv (`peha calibrate --scenario`), panels 2 and 4 also mark where the
controller worked in the closed-loop check (force request at each hold), labelled with the SPGP's
std there.
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
except ImportError:  # the python3 on PATH may lack them
    sys.stderr.write("plot_calibration.py: needs numpy and matplotlib: run it with /usr/bin/python3\n")
    sys.exit(1)


def read_csv(path):
    with open(path) as f:
        rows = [line for line in f if not line.startswith("#")]
    reader = csv.reader(rows)
    header = next(reader)
    data = np.array([[float(x) for x in r] for r in reader if r])
    if data.size == 0:
        raise ValueError(f"{path}: no rows")
    return {name: data[:, i] for i, name in enumerate(header)}


def shade(ax, t, mask):
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        ax.axvspan(t[a], t[b - 1], color="0.85", lw=0, zorder=0)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("report_dir", help="folder written by `peha calibrate` (holds predictions.csv)")
    p.add_argument("--out", default=None, help="output PNG (default: REPORT_DIR/report.png)")
    args = p.parse_args()
    pred_path = os.path.join(args.report_dir, "predictions.csv")
    if not os.path.exists(pred_path):
        sys.stderr.write(f"plot_calibration.py: {pred_path} not found\n")
        return 2
    d = read_csv(pred_path)
    t = d["t_s"]
    held = d["heldout"] > 0.5
    title = os.path.basename(os.path.normpath(args.report_dir))
    summary = os.path.join(args.report_dir, "summary.txt")
    if os.path.exists(summary):
        title = open(summary).readline().strip()

    ops_path = os.path.join(args.report_dir, "operating_points.csv")
    ops = None
    if os.path.exists(ops_path):
        with open(ops_path) as f:
            rows = [line for line in f if not line.startswith("#")]
        reader = csv.DictReader(rows)
        ops = [{k: (v if k == "case" else float(v)) for k, v in r.items()} for r in reader]

    def mark_ops(ax, with_std):
        if not ops:
            return
        ax.plot([o["contraction"] for o in ops], [o["force_cmd_N"] for o in ops], "D", mfc="none", mec="C1", ms=9, mew=2,
                label="E1 operating points (check)")
        if with_std:
            for o in ops:
                ax.annotate(f"{1e3 * o['spgp_std_MPa']:.0f} kPa", (o["contraction"], o["force_cmd_N"]), fontsize=7, color="C1",
                            xytext=(4, 4), textcoords="offset points")

    fig, axes = plt.subplots(2, 2, figsize=(14, 9))
    ax = axes[0, 0]
    shade(ax, t, held)
    ax.plot(t, d["pressure_MPa"], "k", lw=0.8, label="measured")
    ax.plot(t, d["pressure_parametric_MPa"], "C0", lw=0.8, label="g$^{-1}$(F; $\\epsilon$)")
    ax.plot(t, d["pressure_spgp_MPa"], "C3", lw=0.8, label="g$^{-1}$ + SPGP")
    ax.set_xlabel("time [s]" if "t_s" in d else "row")
    ax.set_ylabel("pressure [MPa]")
    ax.set_title("pressure: measured vs model (grey: held out)")
    ax.legend(loc="upper right", fontsize=8)

    ax = axes[0, 1]
    ax.scatter(d["contraction"], d["force_N"], c=d["pressure_MPa"], s=2, cmap="viridis")
    ax.set_xlabel("contraction $\\epsilon$ [-]")
    ax.set_ylabel("load-cell force [N]")
    ax.set_title("calibration data (colour: pressure [MPa])")
    sm = plt.cm.ScalarMappable(cmap="viridis", norm=plt.Normalize(d["pressure_MPa"].min(), d["pressure_MPa"].max()))
    fig.colorbar(sm, ax=ax, label="pressure [MPa]")
    mark_ops(ax, False)
    if ops:
        ax.legend(loc="upper right", fontsize=8)

    ax = axes[1, 0]
    shade(ax, t, held)
    ax.plot(t, 1e3 * (d["pressure_MPa"] - d["pressure_parametric_MPa"]), "C0", lw=0.6, label="parametric")
    ax.plot(t, 1e3 * (d["pressure_MPa"] - d["pressure_spgp_MPa"]), "C3", lw=0.6, label="parametric + SPGP")
    for name, col, colour in (("parametric", "pressure_parametric_MPa", "C0"), ("+SPGP", "pressure_spgp_MPa", "C3")):
        r = 1e3 * (d["pressure_MPa"] - d[col])
        ax.plot([], [], " ", label=f"{name}: held-out RMS {np.sqrt(np.mean(r[held] ** 2)) if held.any() else float('nan'):.1f} kPa")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("pressure residual [kPa]")
    ax.set_title("residual before and after the SPGP")
    ax.legend(loc="upper right", fontsize=8)

    ax = axes[1, 1]
    grid_path = os.path.join(args.report_dir, "spgp_grid.csv")
    if os.path.exists(grid_path):
        g = read_csv(grid_path)
        n = int(round(np.sqrt(len(g["contraction"]))))
        E = g["contraction"].reshape(n, n)
        F = g["force_N"].reshape(n, n)
        S = 1e3 * g["std_MPa"].reshape(n, n)
        cs = ax.contourf(E, F, S, levels=20, cmap="magma_r")
        fig.colorbar(cs, ax=ax, label="SPGP predictive std [kPa]")
        ax.scatter(d["contraction"], d["force_N"], s=0.5, c="w", alpha=0.3, label="data")
        pseudo_path = os.path.join(args.report_dir, "pseudo_inputs.csv")
        if os.path.exists(pseudo_path):
            z = read_csv(pseudo_path)
            ax.plot(z["contraction"], z["force_N"], "c+", ms=8, mew=1.5, label="pseudo-inputs")
        mark_ops(ax, True)
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title("SPGP predictive band over ($\\epsilon$, F)")
    else:
        ax.text(0.5, 0.5, "no SPGP (--no-spgp)", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("contraction $\\epsilon$ [-]")
    ax.set_ylabel("force [N]")

    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = args.out or os.path.join(args.report_dir, "report.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
