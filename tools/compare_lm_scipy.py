#!/usr/bin/python3
"""Cross-check peha's Tendon-spring fit (src/calibration/tendon_spring_fit.cpp) against SciPy.

Runs scipy.optimize.least_squares(method="lm") (MINPACK) on exactly the residual peha minimises,

    r_i = P_i - F_i / g(u_i)   [MPa],  u_i = eps_i + eps0 + F_i / k,  g(u) = a u^2 + b u + c  [N/MPa]

with the solver parameters x = [a, b, c (N/MPa), log(k / 1 N), eps0] and the same guards as the C++
(log k held within +-50, u within +-1e6, the vertex hold of g for a > 0, 1/g continued by its
tangent below g = 1 N/MPa, predictions held within +-1e9 MPa), from the same random starts: restart j
draws from std::mt19937_64 seeded with splitmix64(splitmix64(seed) ^ j), reproduced here bit for bit,
in the same boxes (a in [-50000, 150000], b in [-100000, 0], c in [100, 20000] N/MPa, k log-uniform
in [1e3, 1e6] N, eps0 in [-0.05, 0.05]).

Prints the best cost (0.5 * sum r^2, r in MPa: Ceres' definition), the RMS pressure error and the
wall time; with peha's numbers (--peha-cost/--peha-seconds, or read from --peha-json/--peha-yaml)
also the cost and time ratios, and peha's cost recomputed from its parameters on this CSV when the
file carries them. --json OUT writes everything machine-readably.

Run with /usr/bin/python3 (numpy and scipy live there, not in the python3 on PATH).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

MASK64 = (1 << 64) - 1

# Boxes of the random starts (must match src/calibration/tendon_spring_fit.cpp).
BOX_A = (-50000.0, 150000.0)
BOX_B = (-100000.0, 0.0)
BOX_C = (100.0, 20000.0)
BOX_K = (1e3, 1e6)  # log-uniform
BOX_EPS0 = (-0.05, 0.05)

# Guards (must match the C++).
MAX_ABS_LOG_K = 50.0
MAX_ABS_CONTRACTION = 1e6
MAX_ABS_PREDICTION_MPA = 1e9
GAIN_FLOOR_N_PER_MPA = 1.0  # models::TendonSpringParams::min_gain_N_per_Pa = 1e-6 N/Pa


# --------------------------------------------------------------------------- random starts
def splitmix64(z: int) -> int:
    z = (z + 0x9E3779B97F4A7C15) & MASK64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return z ^ (z >> 31)


class MT19937_64:
    """std::mt19937_64 (C++11 [rand.predef]); 10000th output of the default seed 5489 is
    9981545732273789042."""

    N, M = 312, 156

    def __init__(self, seed: int) -> None:
        mt = [seed & MASK64]
        for i in range(1, self.N):
            prev = mt[-1]
            mt.append((6364136223846793005 * (prev ^ (prev >> 62)) + i) & MASK64)
        self.mt = mt
        self.index = self.N

    def _twist(self) -> None:
        mt = self.mt
        for i in range(self.N):
            x = (mt[i] & 0xFFFFFFFF80000000) | (mt[(i + 1) % self.N] & 0x7FFFFFFF)
            xa = x >> 1
            if x & 1:
                xa ^= 0xB5026F5AA96619E9
            mt[i] = mt[(i + self.M) % self.N] ^ xa
        self.index = 0

    def __call__(self) -> int:
        if self.index >= self.N:
            self._twist()
        y = self.mt[self.index]
        self.index += 1
        y ^= (y >> 29) & 0x5555555555555555
        y ^= (y << 17) & 0x71D67FFFEDA60000
        y ^= (y << 37) & 0xFFF7EEE000000000
        y ^= y >> 43
        return y & MASK64


def random_start(seed: int, restart: int) -> np.ndarray:
    """Restart `restart`'s start, identical to detail::random_initial_params in the C++."""
    engine = MT19937_64(splitmix64(splitmix64(seed & MASK64) ^ restart))

    def draw(lo: float, hi: float) -> float:
        return lo + (hi - lo) * (float(engine() >> 11) * 2.0**-53)

    return np.array([
        draw(*BOX_A),
        draw(*BOX_B),
        draw(*BOX_C),
        draw(math.log(BOX_K[0]), math.log(BOX_K[1])),
        draw(*BOX_EPS0),
    ])


# --------------------------------------------------------------------------- residual
class PressureError:
    """Residuals (MPa) and their Jacobian (N x 5) on one data set; mirrors the C++ guards."""

    def __init__(self, eps: np.ndarray, force_N: np.ndarray, pressure_MPa: np.ndarray) -> None:
        self.eps, self.F, self.P = eps, force_N, pressure_MPa

    def _evaluate(self, x: np.ndarray, want_jac: bool):
        a, b, c, log_k, eps0 = (float(v) for v in x)
        F = self.F
        n = F.size
        if log_k < -MAX_ABS_LOG_K:
            inv_k, dinv_k = math.exp(MAX_ABS_LOG_K), 0.0
        elif log_k > MAX_ABS_LOG_K:
            inv_k, dinv_k = math.exp(-MAX_ABS_LOG_K), 0.0
        else:
            inv_k = math.exp(-log_k)
            dinv_k = -inv_k
        u = self.eps + eps0 + F * inv_k
        du = np.zeros((n, 5))
        du[:, 3] = F * dinv_k
        du[:, 4] = 1.0
        hi = u > MAX_ABS_CONTRACTION
        u = np.where(hi, MAX_ABS_CONTRACTION, u)
        du[hi] = 0.0
        if a > 0.0:
            past = 2.0 * a * u + b > 0.0
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                u_vertex = -b / (2.0 * a)
                du_vertex = np.array([b / (2.0 * a * a), -1.0 / (2.0 * a), 0.0, 0.0, 0.0])
            u = np.where(past, u_vertex, u)
            du[past] = du_vertex
        lo = u < -MAX_ABS_CONTRACTION
        u = np.where(lo, -MAX_ABS_CONTRACTION, u)
        du[lo] = 0.0
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            g = (a * u + b) * u + c
            below = g < GAIN_FLOOR_N_PER_MPA
            f = GAIN_FLOOR_N_PER_MPA
            safe_g = np.where(below, 1.0, g)
            predicted = np.where(below, F * (2.0 * f - g) / (f * f), F / safe_g)
            dpred_dg = np.where(below, -F / (f * f), -F / (safe_g * safe_g))
            capped_hi = ~(predicted < MAX_ABS_PREDICTION_MPA)  # also NaN
            predicted = np.where(capped_hi, MAX_ABS_PREDICTION_MPA, predicted)
            capped_lo = predicted < -MAX_ABS_PREDICTION_MPA
            predicted = np.where(capped_lo, -MAX_ABS_PREDICTION_MPA, predicted)
        residuals = self.P - predicted
        if not want_jac:
            return residuals, None
        dg = np.empty((n, 5))
        dg[:, 0] = u * u
        dg[:, 1] = u
        dg[:, 2] = 1.0
        dg[:, 3] = 0.0
        dg[:, 4] = 0.0
        dg += (2.0 * a * u + b)[:, None] * du
        jac = -(dpred_dg[:, None] * dg)
        jac[capped_hi | capped_lo] = 0.0
        return residuals, jac

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(x, False)[0]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(x, True)[1]

    def cost(self, x: np.ndarray) -> float:
        r = self.residuals(x)
        return 0.5 * float(r @ r)


# --------------------------------------------------------------------------- input
def read_calibration_csv(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(eps, force_N, pressure_MPa) from a calibration CSV (header row of named columns, '#' comments)."""
    required = ("pressure_MPa", "contraction", "force_N")
    columns: dict[str, list[float]] = {name: [] for name in required}
    header: list[str] | None = None
    with path.open(newline="") as stream:
        for line_number, row in enumerate(csv.reader(stream), start=1):
            if not row or row[0].lstrip().startswith("#") or all(not cell.strip() for cell in row):
                continue
            if header is None:
                header = [cell.strip() for cell in row]
                missing = [name for name in required if name not in header]
                if missing:
                    sys.exit(f"{path}:{line_number}: missing column(s) {', '.join(missing)}")
                index = {name: header.index(name) for name in required}
                continue
            if len(row) != len(header):
                sys.exit(f"{path}:{line_number}: {len(row)} fields, header has {len(header)}")
            for name in required:
                cell = row[index[name]].strip()
                try:
                    value = float(cell)
                except ValueError:
                    sys.exit(f"{path}:{line_number}: column {index[name] + 1} ({name}): not a number: {cell!r}")
                if not math.isfinite(value):
                    sys.exit(f"{path}:{line_number}: column {index[name] + 1} ({name}): not finite")
                columns[name].append(value)
    if header is None or len(columns["force_N"]) < 5:
        sys.exit(f"{path}: fewer than 5 data rows")
    return (np.array(columns["contraction"]), np.array(columns["force_N"]), np.array(columns["pressure_MPa"]))


PARAM_KEYS = ("a_N_per_MPa", "b_N_per_MPa", "c_N_per_MPa", "k_N", "eps0")
COST_KEYS = ("best_cost",)
SECONDS_KEYS = ("seconds", "lm_seconds", "fit_seconds", "wall_time_s", "fit_time_s")


def _find(node, predicate):
    """Depth-first search of a parsed JSON/YAML tree for the first mapping/value matching."""
    if isinstance(node, dict):
        hit = predicate(node)
        if hit is not None:
            return hit
        for value in node.values():
            hit = _find(value, predicate)
            if hit is not None:
                return hit
    elif isinstance(node, list):
        for value in node:
            hit = _find(value, predicate)
            if hit is not None:
                return hit
    return None


def read_peha_result(path: Path) -> dict:
    """best_cost, seconds and the parameters (as solver x) from a peha JSON/YAML, where present.

    Looked up anywhere in the tree: `best_cost`; `seconds` (or lm_seconds as in peha's calibration
    file, fit_seconds, wall_time_s, fit_time_s); `restarts`; a mapping with a_N_per_MPa, b_N_per_MPa,
    c_N_per_MPa, k_N, eps0 (the calibration file's `tendon_spring`); `restart_costs` (a list, one
    final cost per restart, for a solve-by-solve comparison)."""
    text = path.read_text()
    if path.suffix.lower() == ".json":
        tree = json.loads(text)
    else:
        try:
            import yaml  # PyYAML, present in Debian's python3
        except ImportError:
            sys.exit(f"{path}: reading YAML needs PyYAML (run with /usr/bin/python3)")
        tree = yaml.safe_load(text)
    out: dict = {}

    def number(keys):
        def pick(mapping):
            for key in keys:
                value = mapping.get(key)
                if isinstance(value, (int, float)) and not isinstance(value, bool):
                    return float(value)
            return None
        return pick

    out["best_cost"] = _find(tree, number(COST_KEYS))
    out["seconds"] = _find(tree, number(SECONDS_KEYS))
    out["restarts"] = _find(tree, number(("restarts",)))
    out["restart_costs"] = _find(tree, lambda m: m.get("restart_costs") if isinstance(m.get("restart_costs"), list)
                                 else None)
    params = _find(tree, lambda m: m if all(isinstance(m.get(k), (int, float)) for k in PARAM_KEYS) else None)
    if params is not None:
        out["x"] = [float(params["a_N_per_MPa"]), float(params["b_N_per_MPa"]), float(params["c_N_per_MPa"]),
                    math.log(float(params["k_N"])), float(params["eps0"])]
    return out


# --------------------------------------------------------------------------- fit
_PROBLEM: PressureError | None = None
_SETTINGS: dict = {}


def _init_worker(eps, force, pressure, settings) -> None:
    global _PROBLEM, _SETTINGS
    _PROBLEM = PressureError(eps, force, pressure)
    _SETTINGS = settings


def _solve(restart: int) -> tuple[int, float, list[float], int, bool, int]:
    """One LM solve from restart `restart`'s start: (j, cost, x, status, success, nfev)."""
    s = _SETTINGS
    x0 = random_start(s["seed"], restart)
    jac = _PROBLEM.jacobian if s["jac"] == "analytic" else "2-point"
    # MINPACK counts function evaluations, Ceres iterations (one residual evaluation each).
    max_nfev = s["max_iterations"] + 1 if s["jac"] == "analytic" else (s["max_iterations"] + 1) * 6
    result = least_squares(_PROBLEM.residuals, x0, jac=jac, method="lm", x_scale="jac", ftol=s["ftol"],
                           xtol=s["xtol"], gtol=s["gtol"], max_nfev=max_nfev)
    cost = float(result.cost) if np.isfinite(result.cost) else math.inf
    return restart, cost, [float(v) for v in result.x], int(result.status), bool(result.success), int(result.nfev)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Fit the Tendon-spring model with scipy.optimize.least_squares(method='lm') on the "
                    "same pressure residual, random starts and boxes as peha, and compare with peha's "
                    "cost and wall time.",
        epilog="Costs are 0.5*sum(r^2) with r in MPa (Ceres' definition). Example: /usr/bin/python3 "
               "tools/compare_lm_scipy.py data.csv --peha-json peha.json --json compare.json")
    parser.add_argument("csv", type=Path, help="calibration CSV (columns pressure_MPa, contraction, force_N)")
    parser.add_argument("--restarts", type=int, default=300, help="random starts (default 300, as peha)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the random starts (default 1, as peha)")
    parser.add_argument("--max-iterations", type=int, default=200,
                        help="per solve, as peha's FitOptions::max_iterations (default 200)")
    parser.add_argument("--jac", choices=("analytic", "2-point"), default="analytic",
                        help="Jacobian for MINPACK: analytic (numpy, default) or 2-point finite differences")
    parser.add_argument("--ftol", type=float, default=1e-6, help="default 1e-6 (Ceres' function_tolerance)")
    parser.add_argument("--xtol", type=float, default=1e-8, help="default 1e-8 (Ceres' parameter_tolerance)")
    parser.add_argument("--gtol", type=float, default=1e-10, help="default 1e-10 (Ceres' gradient_tolerance)")
    parser.add_argument("--processes", type=int, default=1,
                        help="worker processes running restarts in parallel (default 1)")
    parser.add_argument("--peha-yaml", type=Path,
                        help="peha calibration file (YAML) to compare with (optional). It carries the "
                             "parameters and lm_seconds but no cost, so peha's cost is recomputed from its "
                             "parameters on this CSV; peha fitted only its training rows, so expect a ratio "
                             "slightly above 1 when the CSV also holds the held-out rows")
    parser.add_argument("--peha-json", type=Path, help="peha result as JSON (best_cost, seconds, pam{...})")
    parser.add_argument("--peha-cost", type=float, help="peha's best cost (overrides the file's)")
    parser.add_argument("--peha-seconds", type=float, help="peha's wall time in s (overrides the file's)")
    parser.add_argument("--show-starts", type=int, default=0, metavar="K",
                        help="print the first K random starts (to check they match the C++) and continue")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the results as JSON to OUT")
    args = parser.parse_args(argv)
    if args.restarts < 1 or args.processes < 1 or args.max_iterations < 1:
        parser.error("--restarts, --processes and --max-iterations must be >= 1")

    eps, force, pressure = read_calibration_csv(args.csv)
    for j in range(args.show_starts):
        x = random_start(args.seed, j)
        print(f"start {j}: a={x[0]!r} b={x[1]!r} c={x[2]!r} log_k={x[3]!r} eps0={x[4]!r}")

    settings = {"seed": args.seed, "jac": args.jac, "max_iterations": args.max_iterations, "ftol": args.ftol,
                "xtol": args.xtol, "gtol": args.gtol}
    start = time.perf_counter()
    if args.processes == 1:
        _init_worker(eps, force, pressure, settings)
        outcomes = [_solve(j) for j in range(args.restarts)]
    else:
        with ProcessPoolExecutor(args.processes, initializer=_init_worker,
                                 initargs=(eps, force, pressure, settings)) as pool:
            outcomes = list(pool.map(_solve, range(args.restarts), chunksize=4))
    seconds = time.perf_counter() - start

    outcomes.sort(key=lambda o: o[0])
    best = min(outcomes, key=lambda o: (o[1], o[0]))  # lowest cost, ties to the lower index (as peha)
    problem = PressureError(eps, force, pressure)
    best_x = np.array(best[2])
    rms_MPa = math.sqrt(2.0 * best[1] / eps.size)
    costs = np.array([o[1] for o in outcomes])
    near_best = int(np.sum(costs <= best[1] * (1.0 + 1e-6) + 1e-15))

    report = {
        "csv": str(args.csv),
        "samples": int(eps.size),
        "restarts": args.restarts,
        "seed": args.seed,
        "processes": args.processes,
        "jac": args.jac,
        "scipy": {
            "best_cost": best[1],
            "best_restart": best[0],
            "rms_pressure_MPa": rms_MPa,
            "seconds": seconds,
            "restarts_per_s": args.restarts / seconds,
            "restarts_within_1e-6_of_best": near_best,
            "restarts_success": int(sum(o[4] for o in outcomes)),
            "mean_nfev": float(np.mean([o[5] for o in outcomes])),
            "pam": {"a_N_per_MPa": best_x[0], "b_N_per_MPa": best_x[1], "c_N_per_MPa": best_x[2],
                    "k_N": math.exp(best_x[3]), "eps0": best_x[4]},
        },
    }
    print(f"data: {args.csv} ({eps.size} samples); {args.restarts} restarts, seed {args.seed}, "
          f"{args.processes} process(es), {args.jac} Jacobian")
    print(f"scipy lm: best cost {best[1]:.9g} (restart {best[0]}), RMS pressure error {rms_MPa:.6g} MPa "
          f"({rms_MPa * 1e3:.4g} kPa), {near_best}/{args.restarts} restarts within 1e-6 of the best, "
          f"wall time {seconds:.3f} s ({args.restarts / seconds:.1f} restarts/s)")
    print(f"  parameters: a={best_x[0]:.6g} b={best_x[1]:.6g} c={best_x[2]:.6g} N/MPa, "
          f"k={math.exp(best_x[3]):.6g} N, eps0={best_x[4]:.6g}")

    peha: dict = {}
    for path in (args.peha_json, args.peha_yaml):
        if path is not None:
            peha.update({k: v for k, v in read_peha_result(path).items() if v is not None})
    if args.peha_cost is not None:
        peha["best_cost"] = args.peha_cost
    if args.peha_seconds is not None:
        peha["seconds"] = args.peha_seconds
    if peha.get("restarts") is not None and int(peha["restarts"]) != args.restarts:
        print(f"note: peha ran {int(peha['restarts'])} restarts, scipy {args.restarts} (see --restarts)")
    if "x" in peha:
        peha["cost_on_this_csv"] = problem.cost(np.array(peha["x"]))
        print(f"peha parameters on this CSV: cost {peha['cost_on_this_csv']:.9g}, RMS "
              f"{math.sqrt(2.0 * peha['cost_on_this_csv'] / eps.size) * 1e3:.4g} kPa")
    peha_cost = peha.get("best_cost", peha.get("cost_on_this_csv"))
    if peha_cost is not None:
        report["peha_best_cost"] = peha_cost
        report["cost_ratio_peha_over_scipy"] = peha_cost / best[1] if best[1] > 0 else math.nan
        print(f"peha best cost {peha_cost:.9g}; cost ratio peha/scipy {report['cost_ratio_peha_over_scipy']:.9f}")
    if "cost_on_this_csv" in peha:
        report["peha_cost_recomputed"] = peha["cost_on_this_csv"]
    if peha.get("seconds") is not None:
        report["peha_seconds"] = peha["seconds"]
        report["time_ratio_peha_over_scipy"] = peha["seconds"] / seconds
        print(f"peha wall time {peha['seconds']:.3f} s; time ratio peha/scipy "
              f"{report['time_ratio_peha_over_scipy']:.3f} (scipy/peha {seconds / peha['seconds']:.2f}x)")

    restart_costs = peha.get("restart_costs")
    if isinstance(restart_costs, list) and len(restart_costs) == args.restarts:
        # Same starts on both sides: compare solve by solve.
        peha_costs = np.array([float(c) if c is not None else math.inf for c in restart_costs])
        close = np.isclose(peha_costs, costs, rtol=1e-6, atol=0.0)
        agreement = {
            "same_cost_1e-6": int(np.sum(close)),
            "peha_lower": int(np.sum(~close & (peha_costs < costs))),
            "scipy_lower": int(np.sum(~close & (costs < peha_costs))),
        }
        report["per_restart"] = agreement
        print(f"per restart (same starts): same cost to 1e-6 in {agreement['same_cost_1e-6']}, peha lower in "
              f"{agreement['peha_lower']}, scipy lower in {agreement['scipy_lower']} of {args.restarts}")

    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
