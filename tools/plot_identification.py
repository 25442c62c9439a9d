#!/usr/bin/env python3
"""Model vs identified vs measured joint torque per posture of a gravity identification.

Reads an identification file written by `peha identify-gravity` (docs/identification.md) and writes a
PNG beside it (or --out): per measured joint (the file's measured_joints) and posture, the torque the rig measured
(from the sweeps up and down through each posture), the identified model's Y(q) theta and the nominal
model's, and below them the two models' errors against the measurement. Run with /usr/bin/python3
(PyYAML, numpy, matplotlib).
"""
import argparse
import os
import sys

import yaml


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("file", help="identification YAML (peha identify-gravity --out)")
    p.add_argument("--out", help="PNG to write (default: the file with .png)")
    a = p.parse_args(argv)
    with open(a.file, encoding="utf-8") as fh:
        doc = yaml.safe_load(fh)
    if doc.get("kind") != "gravity_identification":
        print(f"{a.file}: not a gravity identification file", file=sys.stderr)
        return 2
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    samples = doc["samples"]
    names = [s["name"] for s in samples]
    measured = np.array([s["measured_Nm"] for s in samples])
    identified = np.array([s["identified_Nm"] for s in samples])
    nominal = np.array([s["nominal_Nm"] for s in samples])
    joints = str(doc["measured_joints"]).split(",")
    if len(joints) != measured.shape[1]:
        print(f"{a.file}: measured_joints names {len(joints)} joints, the samples list {measured.shape[1]} torques", file=sys.stderr)
        return 2
    x = np.arange(len(names))
    cols = min(len(joints), 3)
    rows = (len(joints) + cols - 1) // cols
    fig, axes = plt.subplots(2 * rows, cols, figsize=(6 * cols, 6 * rows), squeeze=False)
    for j, joint in enumerate(joints):
        ax = axes[2 * (j // cols)][j % cols]
        ax.bar(x - 0.27, measured[:, j], 0.27, label="measured (mean of both approaches)", color="0.4")
        ax.bar(x, identified[:, j], 0.27, label="identified model", color="tab:green")
        ax.bar(x + 0.27, nominal[:, j], 0.27, label="nominal model", color="tab:orange")
        ax.set_ylabel(f"{joint} holding torque (Nm)")
        ax.axhline(0, color="k", lw=0.5)
        if j == 0:
            ax.legend(fontsize=8)
        ax.set_xticks(x)
        ax.set_xticklabels([])
        err = axes[2 * (j // cols) + 1][j % cols]
        err.plot(x, identified[:, j] - measured[:, j], "o-", color="tab:green", label="identified - measured")
        err.plot(x, nominal[:, j] - measured[:, j], "s--", color="tab:orange", label="nominal - measured")
        err.axhline(0, color="k", lw=0.5)
        err.set_ylabel(f"{joint} model - measured (Nm)")
        err.set_xticks(x)
        err.set_xticklabels(names, rotation=45, ha="right", fontsize=8)
        if j == 0:
            err.legend(fontsize=8)
    f = doc["fit"]
    fig.suptitle(f"gravity identification: residual RMS {f['residual_rms_Nm']:.3f} Nm (nominal model {f['nominal_rms_Nm']:.3f} Nm), "
                 f"{f['rank']} identified directions")
    fig.tight_layout()
    out = a.out or os.path.splitext(a.file)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(f"written: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
