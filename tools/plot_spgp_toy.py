#!/usr/bin/python3
"""Plot the SPGP fit of Snelson's 1-D benchmark like Fig. 1 of Snelson & Ghahramani (2006).

Input: the CSV that the unit test SpgpToy.TenPseudoInputsTrackTheFullGp writes when the
environment variable PEHA_SPGP_TOY_OUT names a file:

    PEHA_SPGP_TOY_OUT=/tmp/spgp_toy.csv build/release/peha_tests --gtest_filter='SpgpToy.*'
    /usr/bin/python3 tools/plot_spgp_toy.py /tmp/spgp_toy.csv -o docs/img/spgp_toy.png

Columns: kind (test | train | pseudo), x, y, mean, latent_std, noise_std, full_mean,
full_latent_std, full_noise_std. `test` rows carry the predictions of the SPGP and of the dense
full GP on the 301 test inputs; `train` rows the 200 data points; `pseudo` rows the fitted
pseudo-input locations.

Figure: data (small dots), SPGP mean (solid) with the +-2 sigma band of a new observation
(latent variance + noise, shaded), the full GP's mean (dashed) and band (dotted), and the
pseudo-inputs as crosses along the bottom.

Must run on an interpreter with numpy + matplotlib (Debian: /usr/bin/python3).
Exit codes: 0 success, 1 malformed/unreadable CSV, 2 usage errors (argparse).
"""

import argparse
import csv
import math
import sys

EXIT_OK = 0
EXIT_BAD_CSV = 1
DPI = 120
COLUMNS = ["kind", "x", "y", "mean", "latent_std", "noise_std", "full_mean", "full_latent_std",
           "full_noise_std"]


def read_rows(path):
    """Returns {'test': [...], 'train': [...], 'pseudo': [...]} of dicts with float values."""
    groups = {"test": [], "train": [], "pseudo": []}
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: missing columns {', '.join(missing)}")
        for line, row in enumerate(reader, start=2):
            kind = row["kind"]
            if kind not in groups:
                raise ValueError(f"{path}:{line}: unknown kind '{kind}'")
            values = {}
            for key in COLUMNS[1:]:
                text = row[key]
                if text == "":
                    continue
                try:
                    values[key] = float(text)
                except ValueError:
                    raise ValueError(f"{path}:{line}: column {key}: not a number: '{text}'") from None
            groups[kind].append(values)
    for kind in ("test", "train"):
        if not groups[kind]:
            raise ValueError(f"{path}: no '{kind}' rows")
    return groups


def band(rows, mean_key, latent_key, noise_key):
    """x, mean and the 2-sigma half-width of a new observation (latent variance + noise)."""
    x = [r["x"] for r in rows]
    mean = [r[mean_key] for r in rows]
    half = [2.0 * math.sqrt(r[latent_key] ** 2 + r[noise_key] ** 2) for r in rows]
    return x, mean, half


def plot(groups, output, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    test = sorted(groups["test"], key=lambda r: r["x"])
    x, mean, half = (np.asarray(v) for v in band(test, "mean", "latent_std", "noise_std"))
    _, full_mean, full_half = (np.asarray(v) for v in band(test, "full_mean", "full_latent_std",
                                                           "full_noise_std"))
    train_x = [r["x"] for r in groups["train"]]
    train_y = [r["y"] for r in groups["train"]]

    fig, ax = plt.subplots(figsize=(8.0, 4.6))
    ax.plot(train_x, train_y, ".", color="0.45", ms=3.5, label="data (N = %d)" % len(train_x))
    ax.fill_between(x, mean - half, mean + half, color="C3", alpha=0.18, lw=0,
                    label="SPGP mean ± 2σ (new observation)")
    ax.plot(x, mean, color="C3", lw=1.8, label="SPGP mean (M = %d)" % len(groups["pseudo"]))
    ax.plot(x, full_mean, "--", color="C0", lw=1.4, label="full GP mean")
    ax.plot(x, full_mean - full_half, ":", color="C0", lw=1.0)
    ax.plot(x, full_mean + full_half, ":", color="C0", lw=1.0, label="full GP ± 2σ")
    lo, hi = ax.get_ylim()
    pseudo_x = [r["x"] for r in groups["pseudo"]]
    ax.plot(pseudo_x, [lo + 0.04 * (hi - lo)] * len(pseudo_x), "x", color="k", ms=8, mew=1.6,
            label="pseudo-inputs")
    ax.set_ylim(lo, hi + 0.28 * (hi - lo))  # headroom for the legend above the curves
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title(title)
    ax.legend(loc="upper center", ncol=3, fontsize=8, framealpha=0.9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(output, dpi=DPI)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Plot the SPGP fit of Snelson's 1-D benchmark (CSV from the SpgpToy unit test; "
                    "see the module docstring).")
    parser.add_argument("csv", help="CSV written by the test with PEHA_SPGP_TOY_OUT set")
    parser.add_argument("-o", "--output", default="spgp_toy.png", help="image file (default: %(default)s)")
    parser.add_argument("--title", default="SPGP (FITC) on Snelson's 1-D benchmark vs the full GP",
                        help="figure title")
    args = parser.parse_args(argv)
    try:
        groups = read_rows(args.csv)
    except (OSError, ValueError) as err:
        print(f"plot_spgp_toy: {err}", file=sys.stderr)
        return EXIT_BAD_CSV
    plot(groups, args.output, args.title)
    print(f"wrote {args.output}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
