#!/usr/bin/python3
"""peha's SPGP against a genuine dense GP: sklearn's exact GaussianProcessRegressor, same kernel.

Reads what `peha_bench --benchmark_filter=BM_SpgpHeldOutVsDenseGp` wrote (out/bench/spgp_vs_gp/):
data.csv (the training rows and the held-out rows with the SPGP's predictive mean and variance) and
spgp.json (the SPGP's fit time, prediction time per point and held-out RMSE). Fits

    GaussianProcessRegressor(ConstantKernel * RBF(ARD length scales) + WhiteKernel, normalize_y=True)

on the same training rows (inputs standardised like peha's: zero mean, unit sample std), i.e. the
SPGP's covariance c exp(-1/2 sum_d b_d (x_d - x'_d)^2) + sigma^2 delta with every N x N entry exact
(O(N^3) per likelihood evaluation, hyperparameters by L-BFGS-B on the exact marginal likelihood,
sklearn's default optimiser, no restarts), predicts the held-out rows, and reports both held-out
RMSEs (against the noisy targets and the noise-free truth), their ratio, and the time ratios.

Run with /usr/bin/python3 (numpy, scipy and sklearn live there, not in the python3 on PATH).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel


def read_rows(path: Path) -> dict[str, np.ndarray]:
    """Columns of data.csv as arrays, split into train_* and test_*."""
    train, test = [], []
    with path.open(newline="") as stream:
        reader = csv.DictReader(stream)
        for row in reader:
            (test if row["set"] == "test" else train).append(row)
    if not train or not test:
        sys.exit(f"{path}: needs train and test rows")

    def column(rows, name):
        return np.array([float(r[name]) for r in rows])

    out = {
        "train_X": np.column_stack([column(train, "contraction"), column(train, "force_N")]),
        "train_y": column(train, "y_MPa"),
        "test_X": np.column_stack([column(test, "contraction"), column(test, "force_N")]),
        "test_y": column(test, "y_MPa"),
        "test_truth": column(test, "truth_MPa"),
        "spgp_mean": column(test, "spgp_mean_MPa"),
    }
    return out


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(math.sqrt(np.mean((a - b) ** 2)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Compare peha's SPGP with sklearn's exact dense GP on the same rows.")
    parser.add_argument("--dir", type=Path, default=Path("out/bench/spgp_vs_gp"),
                        help="where BM_SpgpHeldOutVsDenseGp wrote data.csv and spgp.json (default out/bench/spgp_vs_gp)")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the comparison as JSON to OUT")
    args = parser.parse_args(argv)

    data = read_rows(args.dir / "data.csv")
    spgp = json.loads((args.dir / "spgp.json").read_text())

    mean = data["train_X"].mean(axis=0)
    scale = data["train_X"].std(axis=0, ddof=1)
    Xs = (data["train_X"] - mean) / scale
    Xt = (data["test_X"] - mean) / scale
    # The SPGP's kernel: c * exp(-1/2 sum_d b_d dx_d^2) + sigma^2 (RBF's length scale l_d = b_d^-1/2).
    kernel = ConstantKernel(1.0, (1e-5, 1e5)) * RBF(length_scale=[1.0, 1.0], length_scale_bounds=(1e-3, 1e3)) \
        + WhiteKernel(0.1, (1e-8, 1e1))
    gp = GaussianProcessRegressor(kernel=kernel, normalize_y=True, random_state=0)
    start = time.perf_counter()
    gp.fit(Xs, data["train_y"])
    fit_s = time.perf_counter() - start
    start = time.perf_counter()
    dense_mean = gp.predict(Xt)
    predict_s = time.perf_counter() - start
    start = time.perf_counter()
    for i in range(200):  # one point at a time, as a controller would ask
        gp.predict(Xt[i:i + 1])
    predict_one_s = (time.perf_counter() - start) / 200

    dense = {
        "train_rows": int(Xs.shape[0]),
        "kernel": str(gp.kernel_),
        "fit_seconds": fit_s,
        "predict_ns_per_point_batch": predict_s / Xt.shape[0] * 1e9,
        "predict_ns_per_point_single": predict_one_s * 1e9,
        "heldout_rmse_MPa": rmse(dense_mean, data["test_y"]),
        "heldout_rmse_vs_truth_MPa": rmse(dense_mean, data["test_truth"]),
        "log_marginal_likelihood": float(gp.log_marginal_likelihood_value_),
    }
    spgp_rmse = rmse(data["spgp_mean"], data["test_y"])
    spgp_rmse_truth = rmse(data["spgp_mean"], data["test_truth"])
    report = {
        "spgp": dict(spgp, heldout_rmse_MPa=spgp_rmse, heldout_rmse_vs_truth_MPa=spgp_rmse_truth),
        "dense_gp_sklearn": dense,
        "rmse_ratio_spgp_over_dense": spgp_rmse / dense["heldout_rmse_MPa"],
        "rmse_vs_truth_ratio_spgp_over_dense": spgp_rmse_truth / dense["heldout_rmse_vs_truth_MPa"],
        "fit_time_ratio_dense_over_spgp": fit_s / spgp["fit_seconds"],
        "predict_time_ratio_dense_single_over_spgp": dense["predict_ns_per_point_single"] / spgp["predict_ns_per_point"],
        "mean_difference_rms_MPa": rmse(data["spgp_mean"], dense_mean),
    }
    print(f"rows: {dense['train_rows']} train, {Xt.shape[0]} held out; dense GP kernel {dense['kernel']}")
    print(f"held-out RMSE: SPGP {spgp_rmse * 1e3:.4f} kPa, dense GP {dense['heldout_rmse_MPa'] * 1e3:.4f} kPa "
          f"(ratio {report['rmse_ratio_spgp_over_dense']:.4f}); against the noise-free truth "
          f"{spgp_rmse_truth * 1e3:.4f} vs {dense['heldout_rmse_vs_truth_MPa'] * 1e3:.4f} kPa")
    print(f"fit: SPGP {spgp['fit_seconds']:.3f} s, dense GP {fit_s:.3f} s ({report['fit_time_ratio_dense_over_spgp']:.1f}x); "
          f"one prediction: SPGP mean+variance {spgp['predict_ns_per_point']:.0f} ns, dense GP "
          f"{dense['predict_ns_per_point_single'] / 1e3:.1f} us "
          f"({report['predict_time_ratio_dense_single_over_spgp']:.0f}x), batch {dense['predict_ns_per_point_batch']:.0f} ns/point")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
