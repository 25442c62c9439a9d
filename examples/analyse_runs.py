#!/usr/bin/env python3
"""Analyse peha runs in Python: Fig. 9 and Fig. 8 style figures, and two runs compared (docs/python.md).

    PYTHONPATH=build/release/python /usr/bin/python3 examples/analyse_runs.py out/e1_nominal \
        --compare out/e1_calibrated --calibration out/calibration/agonist.csv out/calibration/agonist.yaml \
        --out out/analysis

- Fig. 9 style (``fig9_<run>.png``): one column per case of an E1 run: link angle with the finger's
  force (grey while a finger is on), torques (desired, PAM command, PAM measured, motor), muscle
  forces (command and load cell), pressures (command and sensor).
- Fig. 8 style (``fig8_<muscle>.png``): a calibration CSV against its calibration file: measured
  pressure and the model's (parametric alone, parametric + SPGP with its 2-sigma band) over the
  recording, and the pressure error of both.
- Comparison (``compare.png`` and a table): the angle of every case both runs have, one over the
  other, and the summary figures of each release side by side. A calibrated run's variants
  (``<case>_parametric``, ``<case>_spgp``) are compared with the other run's ``<case>``.

Exit code 0, or 2 when a folder is not an E1 run (nothing written) or the two runs share no case.
"""

from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

import peha


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def case_logs(run: dict) -> dict:
    """The per-cycle logs of a run (read_run's result) by case: {case: log}."""
    return {name[len("e1_"):]: log for name, log in run.items() if name.startswith("e1_")}


def fig9(run_dir, out_png) -> dict:
    """Fig. 9 style figure of an E1 run; returns the logs by case."""
    check_e1_run(run_dir)
    logs = case_logs(peha.read_run(run_dir))
    plt = _plt()
    fig, axes = plt.subplots(4, len(logs), figsize=(5 * len(logs), 10), sharex=True, squeeze=False)
    for c, (case, L) in enumerate(sorted(logs.items())):
        t = L["t_s"]
        a = axes[:, c]
        on = L["finger_active"] > 0.5
        a[0].fill_between(t, 0, 1, where=on, color="0.9", transform=a[0].get_xaxis_transform())
        a[0].plot(t, np.degrees(L["plant_angle_rad"]), label="angle (plant)")
        a[0].set_ylabel("angle / deg")
        a[0].set_title(case)
        f = a[0].twinx()
        f.plot(t, L["finger_force_N"], color="tab:red", lw=0.8)
        f.set_ylabel("finger / N", color="tab:red")
        for k, lab in (("tau_desired_Nm", "desired"), ("tau_pam_cmd_Nm", "PAM cmd"),
                       ("tau_pam_measured_Nm", "PAM measured"), ("tau_motor_cmd_Nm", "motor")):
            a[1].plot(t, L[k], label=lab, lw=0.9)
        a[1].set_ylabel("torque / Nm")
        for m in ("agonist", "antagonist"):
            a[2].plot(t, L[f"{m}_force_cmd_N"], label=f"{m} cmd", lw=0.9)
            a[2].plot(t, L[f"{m}_loadcell_N"], label=f"{m} load cell", lw=0.6)
            a[3].plot(t, L[f"{m}_pressure_cmd_MPa"], label=f"{m} cmd", lw=0.9)
            a[3].plot(t, L[f"{m}_pressure_MPa"], label=f"{m} sensor", lw=0.6)
        a[2].set_ylabel("muscle force / N")
        a[3].set_ylabel("pressure / MPa")
        a[3].set_xlabel("t / s")
        for ax in a[1:]:
            ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)
    return logs


def fig8(data_csv, calibration_yaml, out_png) -> dict:
    """Fig. 8 style figure of a calibration; returns the RMS pressure errors (Pa)."""
    data = peha.read_dataset(data_csv)
    cal = peha.Calibration.load(calibration_yaml)
    parametric = peha.inverse_pressure(cal.params, data.force_N, data.contraction)
    mean, std = cal.predict(data.contraction, data.force_N)
    t = data.t_s if data.t_s.size else np.arange(len(data))
    plt = _plt()
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    a.plot(t, data.pressure_Pa * 1e-6, "k", lw=0.8, label="measured")
    a.plot(t, parametric * 1e-6, lw=0.8, label="Tendon-spring model")
    a.plot(t, mean * 1e-6, lw=0.8, label="model + SPGP")
    a.fill_between(t, (mean - 2 * std) * 1e-6, (mean + 2 * std) * 1e-6, alpha=0.3, label="SPGP 2 sigma")
    a.set_ylabel("pressure / MPa")
    a.set_title(f"{cal.muscle}: calibration ({len(data)} samples)")
    a.legend(fontsize=8)
    b.plot(t, (data.pressure_Pa - parametric) * 1e-3, lw=0.6, label="measured - model")
    b.plot(t, (data.pressure_Pa - mean) * 1e-3, lw=0.6, label="measured - (model + SPGP)")
    b.set_ylabel("pressure error / kPa")
    b.set_xlabel("t / s" if data.t_s.size else "sample")
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)
    rms = lambda e: float(np.sqrt(np.mean(e ** 2)))  # noqa: E731
    return {"rms_parametric_Pa": rms(data.pressure_Pa - parametric), "rms_spgp_Pa": rms(data.pressure_Pa - mean)}


# A run with calibrations runs every case as two variants (docs/calibration.md): `<case>_parametric`
# and `<case>_spgp`; they compare with the same case of a run without them.
VARIANT_SUFFIXES = ("_parametric", "_spgp")


def base_case(case: str) -> str:
    """The E1 case a variant belongs to: 'payload_2.5kg_spgp' -> 'payload_2.5kg'."""
    for suffix in VARIANT_SUFFIXES:
        if case.endswith(suffix):
            return case[: -len(suffix)]
    return case


def case_pairs(cases_a, cases_b) -> list[tuple[str, str]]:
    """(case of A, case of B) to compare: the same case, or a case and each of its variants."""
    return [(ca, cb) for ca in sorted(cases_a) for cb in sorted(cases_b)
            if ca == cb or (base_case(ca) == base_case(cb) and (base_case(ca) == ca or base_case(cb) == cb))]


class RunError(Exception):
    """A folder that is not an E1 run, or two runs with nothing to compare."""


def check_e1_run(run_dir) -> None:
    """RunError naming the folder unless it is an E1 run directory (its logs e1_<case>.csv)."""
    path = pathlib.Path(run_dir)
    if not path.is_dir():
        raise RunError(f"{run_dir}: no such run directory (an E1 run such as out/e1_nominal)")
    if not any(path.glob("e1_*.csv")):
        raise RunError(f"{run_dir}: no E1 logs (e1_<case>.csv) in it; is it an E1 run?")


def compare(run_a, run_b, out_png) -> list[tuple]:
    """Angles of the cases both runs have (a case and its calibrated variants), one over the other;
    returns rows (case A, case B, release, figure, a, b). RunError when they share no case."""
    check_e1_run(run_a)
    check_e1_run(run_b)
    A, B = peha.read_run(run_a), peha.read_run(run_b)
    la, lb = case_logs(A), case_logs(B)
    pairs = case_pairs(la, lb)
    if not pairs:
        raise RunError(f"{run_a} and {run_b} have no E1 case in common ({', '.join(sorted(la))} vs {', '.join(sorted(lb))})")
    name_a, name_b = pathlib.Path(run_a).name, pathlib.Path(run_b).name
    bases = sorted({base_case(ca) for ca, _ in pairs})
    plt = _plt()
    fig, axes = plt.subplots(len(bases), 1, figsize=(10, 3 * len(bases)), squeeze=False)
    for ax, base in zip(axes[:, 0], bases):
        cases_a = sorted({ca for ca, cb in pairs if base_case(ca) == base})
        cases_b = sorted({cb for ca, cb in pairs if base_case(cb) == base})
        for logs, cases, name, style in ((la, cases_a, name_a, "-"), (lb, cases_b, name_b, "--")):
            for case in cases:
                L = logs[case]
                ax.plot(L["t_s"], np.degrees(L["plant_angle_rad"]), style, label=f"{name}: {case}", lw=0.9)
        ax.set_title(base)
        ax.set_ylabel("angle / deg")
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("t / s")
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)
    rows = []
    sa = {(r["case"], r["release"]): r for r in A.get("summary", [])}
    sb = {(r["case"], r["release"]): r for r in B.get("summary", [])}
    releases = sorted({rel for _, rel in sa} & {rel for _, rel in sb})
    for ca, cb in pairs:
        for release in releases:
            if (ca, release) not in sa or (cb, release) not in sb:
                continue
            ra, rb = sa[(ca, release)], sb[(cb, release)]
            for fig_name in ("angle_at_release_deg", "drift_deg", "peak_finger_force_N", "min_wire_tension_N"):
                if fig_name in ra and fig_name in rb:
                    rows.append((ca, cb, release, fig_name, float(ra[fig_name]), float(rb[fig_name])))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", help="an E1 run directory (out/<run>)")
    ap.add_argument("--compare", help="a second run directory to compare with")
    ap.add_argument("--calibration", nargs=2, metavar=("CSV", "YAML"), help="calibration data and file (Fig. 8)")
    ap.add_argument("--out", default="out/analysis", help="folder for the figures")
    args = ap.parse_args(argv)
    try:
        return analyse(args)
    except RunError as e:
        print(f"analyse_runs.py: {e}", file=sys.stderr)
        return 2


def analyse(args) -> int:
    """The figures and the table main() was asked for; RunError before anything is written."""
    check_e1_run(args.run)
    if args.compare:
        check_e1_run(args.compare)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig9(args.run, out / f"fig9_{pathlib.Path(args.run).name}.png")
    print(f"written: {out}/fig9_{pathlib.Path(args.run).name}.png")
    if args.calibration:
        rms = fig8(*args.calibration, out / f"fig8_{pathlib.Path(args.calibration[0]).stem}.png")
        print(f"written: {out}/fig8_{pathlib.Path(args.calibration[0]).stem}.png  "
              f"(pressure RMS: model {rms['rms_parametric_Pa'] / 1e3:.1f} kPa, model + SPGP {rms['rms_spgp_Pa'] / 1e3:.1f} kPa)")
    if args.compare:
        rows = compare(args.run, args.compare, out / "compare.png")
        print(f"A = {args.run}, B = {args.compare}")
        print(f"{'case A':<16}{'case B':<28}{'release':<11}{'figure':<22}{'A':>10}{'B':>10}")
        for case_a, case_b, release, name, a, b in rows:
            print(f"{case_a:<16}{case_b:<28}{release:<11}{name:<22}{a:>10.3f}{b:>10.3f}")
        print(f"written: {out}/compare.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
