#!/usr/bin/python3
"""Fit the simulated plant's muscle force law to the real Festo DMSP force maps.

The law (docs/plant-muscle.md, include/peha/sim/plant_muscle.hpp):

    F_static(P, u) = delta * softplus(z / delta)
    z(P, u)        = g(u) * q(P) + f_el(u)
    q(P)           = P * (1 + beta * P / 1 MPa)
    g(u)           = g0 * (1 + kappa) * s / (1 + kappa * s),  s = (1 - c) * d + c * d^2
    d(u)           = w * softplus((u_m - u) / w) / u_m
    f_el(u)        = k_e * (E(u) - 1) - k_l * u
    E(u)           = exp(-u / u_e) for u >= u_k, else exp(-u_k/u_e) * (1 - (u - u_k) / u_e)

Ten parameters per muscle (g0, kappa, c, u_m, w, beta, k_e, u_e, k_l, delta) are fitted with
scipy.optimize.least_squares (trust-region reflective, bounded, deterministic multi-start) on the
force error in N. The knee u_k is fixed at the most stretched contraction in the fitted map (the
exponential is only trusted where there are data). The rounding width w is capped at 0.03 so that
the gain really ends near u_m: with a free w the fit uses a wide softplus as curvature and the force
then fades out over a long tail (DMSP-40 free contraction 0.41 at 0.8 MPa instead of about 0.35,
while the datasheet's curves, extended linearly, reach zero at 0.29..0.32). The hysteresis
parameters and the pressure clamp are not in static maps; they come from the command line.

Zero or negative forces in the maps mark points where the muscle cannot pull (the datasheet's lines
run on below zero; Martens & Boblan write 0 where the muscle could not reach that length). They are
kept as F = 0 targets: the law must predict (almost) no force there, which is what pins the pressure
threshold and the end of the contraction range. Errors are reported against these clipped targets,
and separately on the positive points only.

Sources (read from --data-dir, never copied into the repository):
  DMSP-40: festo_datasheet_DMSP-40_digitized.csv (fit)
  DMSP-10: festo_datasheet_DMSP-10_digitized.csv (fit), martens2017_DMSP-10-250_forcemap.csv (check)

Writes <out-dir>/dmsp40.yaml and <out-dir>/dmsp10.yaml (keys as peha::sim::read_plant_muscle
expects), prints the fit errors, and with --plot draws measured points vs fitted curves.

Must run on an interpreter with numpy + scipy + matplotlib (Debian: /usr/bin/python3).
Exit codes: 0 success, 1 unreadable or malformed data, 2 usage errors (argparse).
"""

import argparse
import csv
import math
import os
import sys

import numpy as np
from scipy.optimize import least_squares

PRESSURE_UNIT_PA = 1.0e6  # beta is "per MPa"
WIRE_LIMIT_N = 2000.0     # PAM force ceiling (the 1.7 mm inner wire broke at 2250 N); drawn on the plot
SUPPLY_PA = 0.8e6         # supply (tank) pressure, Pa gauge; drawn extrapolated if beyond the map

# name, lower bound, upper bound (inside the ranges read_plant_muscle accepts)
PARAMS = [
    ("gain_N_per_Pa", 1e-6, 1.0),
    ("gain_saturation", 0.0, 20.0),
    ("gain_quadratic_fraction", 0.0, 1.0),
    ("gain_zero_contraction", 0.1, 0.6),
    ("gain_smoothing_contraction", 0.005, 0.03),
    ("pressure_curvature_per_MPa", -0.3, 1.0),
    ("elastic_force_N", 0.0, None),          # upper bound scales with the map's force range
    ("elastic_contraction_scale", 0.005, 0.2),
    ("elastic_stiffness_N", 0.0, None),
    ("threshold_smoothing_N", 0.05, None),
]
INDEX = {name: i for i, (name, _, _) in enumerate(PARAMS)}
N_STARTS = 24
SEED = 20140914  # deterministic multi-start


class DataError(Exception):
    """A data file is missing or malformed."""


def read_map(path, pressure_column, pressure_scale_Pa):
    """Reads a force map CSV: '#' comment lines, a header row, then numbers.

    Returns (pressure_Pa, contraction, force_N) arrays.
    """
    rows = []
    header = None
    try:
        with open(path, newline="") as f:
            for line_no, line in enumerate(f, start=1):
                if line.startswith("#") or not line.strip():
                    continue
                cells = next(csv.reader([line]))
                if header is None:
                    header = [c.strip() for c in cells]
                    for col in (pressure_column, "contraction", "force_N"):
                        if col not in header:
                            raise DataError(f"{path}:{line_no}: missing column '{col}' in header")
                    continue
                if len(cells) != len(header):
                    raise DataError(f"{path}:{line_no}: expected {len(header)} columns, "
                                    f"found {len(cells)}")
                try:
                    values = dict(zip(header, (float(c) for c in cells)))
                except ValueError as e:
                    raise DataError(f"{path}:{line_no}: not a number: {e}") from None
                rows.append((values[pressure_column] * pressure_scale_Pa, values["contraction"],
                             values["force_N"]))
    except OSError as e:
        raise DataError(f"{path}: cannot read: {e.strerror}") from None
    if not rows:
        raise DataError(f"{path}: no data rows")
    a = np.array(rows, dtype=float)
    if not np.all(np.isfinite(a)):
        raise DataError(f"{path}: non-finite value")
    return a[:, 0], a[:, 1], a[:, 2]


def softplus(x):
    return np.maximum(x, 0.0) + np.log1p(np.exp(-np.abs(x)))


def static_force(theta, knee, pressure_Pa, u):
    """F_static(P, u) in N, exactly as src/sim/plant_muscle.cpp computes it (inside the clamps)."""
    g0, kappa, c, um, w, beta, ke, ue, kl, delta = theta
    d = w * softplus((um - u) / w) / um
    s = (1.0 - c) * d + c * d * d
    g = g0 * (1.0 + kappa) * s / (1.0 + kappa * s)
    q = pressure_Pa * (1.0 + beta * pressure_Pa / PRESSURE_UNIT_PA)
    above = u >= knee
    E = np.where(above, np.exp(-np.where(above, u, knee) / ue),
                 math.exp(-knee / ue) * (1.0 - (u - knee) / ue))
    z = g * q + ke * (E - 1.0) - kl * u
    return delta * softplus(z / delta)


def fit(pressure_Pa, u, target_N):
    """Bounded least squares on the force error, best of N_STARTS deterministic starts."""
    f_range = float(target_N.max())
    knee = float(u.min())
    lo = np.array([b[1] for b in PARAMS], dtype=float)
    hi = np.array([b[2] if b[2] is not None else np.nan for b in PARAMS], dtype=float)
    hi[INDEX["elastic_force_N"]] = 10.0 * f_range
    hi[INDEX["elastic_stiffness_N"]] = 100.0 * f_range
    hi[INDEX["threshold_smoothing_N"]] = 0.02 * f_range  # at most 2 % of the range
    # A physically plausible first start: gain from the steepest force/pressure, threshold of a few
    # percent of the range, rubber stiffening over ~3 % of stretch.
    start = {
        "gain_N_per_Pa": float(np.max(target_N / np.maximum(pressure_Pa, 1e5))),
        "gain_saturation": 0.5,
        "gain_quadratic_fraction": 0.3,
        "gain_zero_contraction": 0.3,
        "gain_smoothing_contraction": 0.02,
        "pressure_curvature_per_MPa": 0.0,
        "elastic_force_N": 0.05 * f_range,
        "elastic_contraction_scale": 0.03,
        "elastic_stiffness_N": 0.01 * f_range,
        "threshold_smoothing_N": 0.003 * f_range,
    }
    first = np.array([start[name] for name, _, _ in PARAMS])
    rng = np.random.default_rng(SEED)
    starts = [np.clip(first, lo, hi)]
    for _ in range(N_STARTS - 1):
        # log-uniform around the plausible start, inside the bounds
        jitter = np.exp(rng.uniform(-1.0, 1.0, size=first.size))
        s = first * jitter
        s[INDEX["pressure_curvature_per_MPa"]] = rng.uniform(-0.2, 0.3)
        s[INDEX["gain_quadratic_fraction"]] = rng.uniform(0.0, 1.0)
        starts.append(np.clip(s, lo, hi))
    best = None
    for x0 in starts:
        x0 = np.clip(x0, lo + 1e-12 * (1 + np.abs(lo)), hi - 1e-12 * (1 + np.abs(hi)))
        r = least_squares(lambda th: static_force(th, knee, pressure_Pa, u) - target_N, x0,
                          bounds=(lo, hi), x_scale="jac", max_nfev=20000)
        if best is None or r.cost < best.cost:
            best = r
    return best.x, knee


def errors(theta, knee, pressure_Pa, u, force_N):
    """Error statistics against a map; non-positive map forces are F = 0 targets."""
    target = np.maximum(force_N, 0.0)
    res = static_force(theta, knee, pressure_Pa, u) - target
    pos = force_N > 0.0
    f_range = float(target.max() - target.min())
    return {
        "n": int(res.size),
        "n_nonpositive": int((~pos).sum()),
        "rms_N": float(np.sqrt(np.mean(res ** 2))),
        "max_N": float(np.max(np.abs(res))),
        "rms_pos_N": float(np.sqrt(np.mean(res[pos] ** 2))),
        "max_pos_N": float(np.max(np.abs(res[pos]))),
        "range_N": f_range,
    }


def describe(stats):
    rel_rms = 100 * stats["rms_N"] / stats["range_N"]
    rel_max = 100 * stats["max_N"] / stats["range_N"]
    return (f"RMS {stats['rms_N']:.1f} N, max {stats['max_N']:.1f} N "
            f"({rel_rms:.2f} % / {rel_max:.2f} % of the 0..{stats['range_N']:.0f} N range; "
            f"{stats['n']} points, {stats['n_nonpositive']} non-positive taken as 0; "
            f"positive points only: RMS {stats['rms_pos_N']:.1f} N, "
            f"max {stats['max_pos_N']:.1f} N)")


def zero_force_contraction(theta, knee, pressure_Pa):
    """Contraction where z = 0 (F = delta*ln2, the smooth end of the force) at `pressure_Pa`."""
    delta = theta[INDEX["threshold_smoothing_N"]]
    u = np.linspace(-0.1, 1.0, 110001)
    F = static_force(theta, knee, np.full_like(u, pressure_Pa), u)
    below = np.nonzero(F <= delta * math.log(2.0))[0]
    return float(u[below[0]]) if below.size else float("nan")


def threshold_pressure(theta, knee, u):
    """Pressure where z = 0 at contraction `u` (NaN if the muscle pulls at P = 0 or never)."""
    delta = theta[INDEX["threshold_smoothing_N"]]
    P = np.linspace(0.0, 1.0e6, 100001)
    F = static_force(theta, knee, P, np.full_like(P, u))
    above = np.nonzero(F >= delta * math.log(2.0))[0]
    if not above.size or above[0] == 0:
        return float("nan")
    return float(P[above[0]])


def write_yaml(path, name, theta, knee, args, fitted_file, fit_stats, checks):
    lines = [
        f"# Plant muscle force law of the Festo {name} (the simulator's truth; "
        "see docs/plant-muscle.md).",
        "# Generated by tools/fit_plant_muscle.py -- do not edit by hand, re-run the tool instead.",
        f"# Fitted to: {fitted_file}",
        f"#   fit error: {describe(fit_stats)}",
    ]
    for check_file, stats in checks:
        lines.append(f"# Independent check against: {check_file}")
        lines.append(f"#   error: {describe(stats)}")
    lines += [
        "# Hysteresis and the pressure clamp are not fitted (static maps): command-line values.",
        f"name: {name}",
    ]
    for (key, _, _), value in zip(PARAMS, theta):
        lines.append(f"{key}: {value:.8g}")
    lines += [
        f"elastic_knee_contraction: {knee:.8g}",
        f"max_pressure_Pa: {args.max_pressure_kPa * 1e3:.8g}",
        f"hysteresis_fraction: {args.hysteresis_fraction:.8g}",
        f"hysteresis_rate_scale_1ps: {args.hysteresis_rate_scale:.8g}",
    ]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def plot(path, panels):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # Top row: map vs law; bottom row: residuals (law - target), the part a reader must judge.
    fig, axes = plt.subplots(2, len(panels), figsize=(6.0 * len(panels), 8.4),
                             gridspec_kw=dict(height_ratios=[5.2, 2.4]), squeeze=False)
    for ax, rax, (title, theta, knee, (P, u, F), stats) in zip(axes[0], axes[1], panels):
        pressures = np.unique(P)
        cmap = plt.get_cmap("viridis")
        u_curve = np.linspace(min(u.min(), 0.0) - 0.01, 0.4, 400)
        for i, p in enumerate(pressures):
            color = cmap(i / max(len(pressures) - 1, 1))
            ax.plot(u_curve, static_force(theta, knee, np.full_like(u_curve, p), u_curve),
                    color=color, lw=1.3, label=f"{p / 1e3:.0f} kPa")
            sel = P == p
            pos = sel & (F > 0)
            nonpos = sel & (F <= 0)
            ax.plot(u[pos], F[pos], "o", ms=4.5, color=color)
            ax.plot(u[nonpos], np.zeros(nonpos.sum()), "o", ms=6, mfc="none", mec=color)
            for subset, face in ((pos, color), (nonpos, "none")):
                res = static_force(theta, knee, P[subset], u[subset]) - np.maximum(F[subset], 0.0)
                rax.plot(u[subset], res, "o", ms=3.5, color=color, mfc=face)
        if pressures.max() < SUPPLY_PA:
            ax.plot(u_curve, static_force(theta, knee, np.full_like(u_curve, SUPPLY_PA), u_curve),
                    color="0.4", lw=1.0, ls="--", label=f"{SUPPLY_PA / 1e3:.0f} kPa (extrapolated)")
        if np.max(F) > WIRE_LIMIT_N:
            ax.axhline(WIRE_LIMIT_N, color="r", ls=":", lw=1.0)
            ax.text(u_curve[-1], WIRE_LIMIT_N, "2000 N wire limit", color="r", ha="right",
                    va="bottom", fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("contraction u = (L0 - L) / L0")
        ax.set_ylabel("force [N]")
        ax.set_xlim(u_curve[0], u_curve[-1])
        ax.set_ylim(-0.03 * np.max(F), 1.05 * np.max(F))
        ax.grid(alpha=0.3)
        ax.text(0.98, 0.97, f"RMS {stats['rms_N']:.1f} N, max {stats['max_N']:.1f} N\n"
                            "dots: map, hollow: map <= 0 (target 0)\nlines: fitted law",
                transform=ax.transAxes, ha="right", va="top", fontsize=8,
                bbox=dict(fc="white", ec="0.7", alpha=0.9))
        ax.legend(fontsize=7, loc="center right", title="pressure", title_fontsize=7)
        rax.axhline(0.0, color="k", lw=0.8)
        rax.set_xlim(u_curve[0], u_curve[-1])
        rax.set_xlabel("contraction u = (L0 - L) / L0")
        rax.set_ylabel("law - map [N]")
        rax.grid(alpha=0.3)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Fit the simulated plant's muscle force law (docs/plant-muscle.md) to the "
                    "Festo DMSP-40 and DMSP-10 force maps and write configs/plant/dmsp40.yaml and "
                    "dmsp10.yaml.",
        epilog="Example: /usr/bin/python3 tools/fit_plant_muscle.py --data-dir ../shared/data/pam "
               "--out-dir configs/plant --plot docs/img/plant_muscle_fit.png")
    parser.add_argument("--data-dir", required=True,
                        help="directory with festo_datasheet_DMSP-40_digitized.csv, "
                             "festo_datasheet_DMSP-10_digitized.csv and "
                             "martens2017_DMSP-10-250_forcemap.csv")
    parser.add_argument("--out-dir", required=True, help="where dmsp40.yaml and dmsp10.yaml go")
    parser.add_argument("--plot", metavar="PNG", help="also draw measured points vs fitted curves")
    parser.add_argument("--hysteresis-fraction", type=float, default=0.05,
                        help="h: half-width of the hysteresis loop as a fraction of F "
                             "(default 0.05)")
    parser.add_argument("--hysteresis-rate-scale", type=float, default=0.02,
                        help="r_h in 1/s: contraction rate at which the hysteresis reaches "
                             "tanh(1) of its size (default 0.02)")
    parser.add_argument("--max-pressure-kPa", type=float, default=1000.0,
                        help="pressure clamp of the law, kPa (default 1000; supply is 800)")
    args = parser.parse_args(argv)
    if not 0.0 <= args.hysteresis_fraction <= 0.5:
        parser.error("--hysteresis-fraction must be in [0, 0.5]")
    if not 1e-4 <= args.hysteresis_rate_scale <= 100.0:
        parser.error("--hysteresis-rate-scale must be in [1e-4, 100]")
    if not 100.0 <= args.max_pressure_kPa <= 2000.0:
        parser.error("--max-pressure-kPa must be in [100, 2000]")

    def data(name):
        return os.path.join(args.data_dir, name)

    def shown(name):
        return "../shared/data/pam/" + name  # machine-independent name for the file headers

    f40 = "festo_datasheet_DMSP-40_digitized.csv"
    f10 = "festo_datasheet_DMSP-10_digitized.csv"
    fm10 = "martens2017_DMSP-10-250_forcemap.csv"
    try:
        map40 = read_map(data(f40), "pressure_kPa", 1e3)
        map10 = read_map(data(f10), "pressure_kPa", 1e3)
        mart10 = read_map(data(fm10), "pressure_Pa", 1.0)
    except DataError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1

    os.makedirs(args.out_dir, exist_ok=True)
    panels = []
    for name, out_name, (P, u, F), checks in [
            ("DMSP-40", "dmsp40.yaml", map40, []),
            ("DMSP-10", "dmsp10.yaml", map10, [(fm10, mart10)])]:
        theta, knee = fit(P, u, np.maximum(F, 0.0))
        beta = theta[INDEX["pressure_curvature_per_MPa"]]
        slope_at_max = 1.0 + 2.0 * beta * args.max_pressure_kPa * 1e3 / PRESSURE_UNIT_PA
        if slope_at_max <= 0.0:
            print(f"error: {name}: fitted pressure curvature makes F fall with P below the clamp",
                  file=sys.stderr)
            return 1
        fitted_file = f40 if name == "DMSP-40" else f10
        fit_stats = errors(theta, knee, P, u, F)
        check_stats = [(shown(cf), errors(theta, knee, *cm)) for cf, cm in checks]
        out_path = os.path.join(args.out_dir, out_name)
        write_yaml(out_path, name, theta, knee, args, shown(fitted_file), fit_stats, check_stats)

        print(f"{name}: wrote {out_path}")
        print(f"  fit   {fitted_file}: {describe(fit_stats)}")
        for cf, stats in check_stats:
            print(f"  check {os.path.basename(cf)}: {describe(stats)}")
        for (key, _, _), value in zip(PARAMS, theta):
            print(f"    {key} = {value:.6g}")
        print(f"    elastic_knee_contraction = {knee:.6g} (fixed: most stretched point of the map)")
        for p_kPa in (0, 100, 300, 600, 800):
            p = p_kPa * 1e3
            forces = ", ".join(f"F(u={uu:g}) = {static_force(theta, knee, p, uu):7.1f} N"
                               for uu in (-0.03, 0.0, 0.1))
            print(f"  P = {p_kPa:3d} kPa: {forces}, "
                  f"zero-force contraction {zero_force_contraction(theta, knee, p):.3f}")
        for uu in (0.05, 0.1, 0.15, 0.2, 0.25):
            p_th = threshold_pressure(theta, knee, uu)
            print(f"  threshold pressure at u = {uu:.2f}: {p_th / 1e3:6.1f} kPa")
        panels.append((f"{name}: fit to {fitted_file}", theta, knee, (P, u, F), fit_stats))
        for cf, cm in checks:
            panels.append((f"{name} law (datasheet fit) vs {cf}\n(independent check)", theta, knee,
                           cm, errors(theta, knee, *cm)))

    if args.plot:
        plot(args.plot, panels)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
