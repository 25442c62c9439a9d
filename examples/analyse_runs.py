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
  other, and the summary figures of each release side by side.
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
    return {name.split("_", 1)[1] if name.startswith("e1_") else name: log
            for name, log in run.items() if name != "summary"}


def fig9(run_dir, out_png) -> dict:
    """Fig. 9 style figure of an E1 run; returns the logs by case."""
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


def compare(run_a, run_b, out_png) -> list[tuple]:
    """Angles of the cases both runs have, one over the other; returns rows (case, release, figure, a, b)."""
    A, B = peha.read_run(run_a), peha.read_run(run_b)
    la, lb = case_logs(A), case_logs(B)
    common = sorted(set(la) & set(lb))
    plt = _plt()
    fig, axes = plt.subplots(len(common) or 1, 1, figsize=(10, 3 * max(len(common), 1)), squeeze=False)
    for ax, case in zip(axes[:, 0], common):
        for L, name in ((la[case], pathlib.Path(run_a).name), (lb[case], pathlib.Path(run_b).name)):
            ax.plot(L["t_s"], np.degrees(L["plant_angle_rad"]), label=name, lw=0.9)
        ax.set_title(case)
        ax.set_ylabel("angle / deg")
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("t / s")
    fig.tight_layout()
    fig.savefig(out_png, dpi=90)
    plt.close(fig)
    rows = []
    sa = {(r["case"], r["release"]): r for r in A.get("summary", [])}
    sb = {(r["case"], r["release"]): r for r in B.get("summary", [])}
    for key in sorted(set(sa) & set(sb)):
        for fig_name in ("angle_at_release_deg", "drift_deg", "peak_finger_force_N", "min_wire_tension_N"):
            if fig_name in sa[key] and fig_name in sb[key]:
                rows.append((key[0], key[1], fig_name, float(sa[key][fig_name]), float(sb[key][fig_name])))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", help="an E1 run directory (out/<run>)")
    ap.add_argument("--compare", help="a second run directory to compare with")
    ap.add_argument("--calibration", nargs=2, metavar=("CSV", "YAML"), help="calibration data and file (Fig. 8)")
    ap.add_argument("--out", default="out/analysis", help="folder for the figures")
    args = ap.parse_args(argv)
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
        print(f"{'case':<16}{'release':<11}{'figure':<22}{'A':>10}{'B':>10}")
        for case, release, name, a, b in rows:
            print(f"{case:<16}{release:<11}{name:<22}{a:>10.3f}{b:>10.3f}")
        print(f"written: {out}/compare.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
