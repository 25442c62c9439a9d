#!/usr/bin/python3
"""Fault matrix picture (`peha faults --config configs/e1_one_dof.yaml` or `configs/right_arm.yaml`).

Reads RUN_DIR/faults.csv and writes RUN_DIR/faults.png: one row per fault kind, one column per
moment (E1: holding, push, after_release; E3: holding, moving, elbow_moving, elbow_flexed). Each cell
is coloured by the control cycles from the fault to its detection (green <= 5, amber later) or, when
nothing detected it, grey if no limit was exceeded over the row's 5 s (a fault the sensors cannot see
while it changes nothing: a frozen encoder on a still joint) and red if one was; it shows the flag
that caught it and the safe state; a black frame marks a limit exceeded, a dashed one an incomplete
log. Run with /usr/bin/python3.
"""
import argparse
import csv
import os
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle
except ImportError:
    sys.stderr.write("plot_faults.py: needs matplotlib: run it with /usr/bin/python3\n")
    sys.exit(1)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_dir")
    p.add_argument("--out", help="output PNG (default RUN_DIR/faults.png)")
    a = p.parse_args()
    path = os.path.join(a.run_dir, "faults.csv")
    if not os.path.exists(path):
        sys.stderr.write(f"plot_faults.py: {path} not found\n")
        return 2
    rows = [r for r in csv.DictReader(open(path)) if r["fault"] != "none"]
    nominal = [r for r in csv.DictReader(open(path)) if r["fault"] == "none"]
    faults = list(dict.fromkeys(r["fault"] for r in rows))
    moments = list(dict.fromkeys(r["moment"] for r in rows))
    fig, ax = plt.subplots(figsize=(3.2 * len(moments) + 2.5, 0.42 * len(faults) + 1.6))
    for r in rows:
        x, y = moments.index(r["moment"]), faults.index(r["fault"])
        cycles = r["detection_cycles"]
        if r["detected"] != "1":
            harmless = r["limits_exceeded"] == "0"
            colour, text = ("#cccccc", "not detected\n(no limit exceeded)") if harmless else ("#e06666", "not detected")
        else:
            c = float(cycles)
            colour = "#93c47d" if c <= float(r.get("prompt_cycles", 5) or 5) else "#f6b26b"
            text = f"{r['flag']} {c:.0f} cyc, {r['safe_state']}"
        ax.add_patch(Rectangle((x, y), 1, 1, facecolor=colour, edgecolor="white"))
        if r["limits_exceeded"] != "0":
            # Dotted: physics forbids any safe state to keep the limit (reason in faults.md); solid: a miss.
            forbidden = r.get("physics_forbids", "") not in ("", "-")
            ax.add_patch(Rectangle((x + 0.03, y + 0.06), 0.94, 0.88, fill=False, edgecolor="black", lw=2, ls=":" if forbidden else "-"))
            if forbidden:
                text += "\n(physics forbids)"
        if r["log_complete"] != "1":
            ax.add_patch(Rectangle((x + 0.06, y + 0.12), 0.88, 0.76, fill=False, edgecolor="black", ls="--"))
        ax.text(x + 0.5, y + 0.5, text, ha="center", va="center", fontsize=7)
    ax.set_xlim(0, len(moments))
    ax.set_ylim(len(faults), 0)
    ax.set_xticks([i + 0.5 for i in range(len(moments))], moments)
    ax.set_yticks([i + 0.5 for i in range(len(faults))], faults)
    experiment = (rows or nominal or [{}])[0].get("experiment", "E1")
    # The scenario the matrix ran on: the run's copy of its config names it on its first line.
    scenario = ""
    config_copy = os.path.join(a.run_dir, "config.yaml")
    if os.path.exists(config_copy):
        with open(config_copy, encoding="utf-8") as fh:
            first = fh.readline()
        if first.startswith("# peha run copy of "):
            scenario = os.path.basename(first.strip()[len("# peha run copy of "):])
    e3_where = f"E3 on {scenario or 'the arm scenario'} in process, faults on R_EFE"
    where = {"E1": "E1 in process", "E3": e3_where}.get(experiment, experiment)
    title = (f"Fault matrix, {where}\ndetection: green <= 5 cycles (a stuck cell: its window), amber later; none: grey (no limit exceeded) or red;\nframe = limit exceeded "
             "(dotted where physics forbids any safe state to keep it, solid = a miss of the designed outcome)")
    if nominal:
        title += "\nnominal run without a fault: " + ("faulted by " + nominal[0]["flag"] if nominal[0]["detected"] == "1" else "no fault")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    out = a.out or os.path.join(a.run_dir, "faults.png")
    fig.savefig(out, dpi=110)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
