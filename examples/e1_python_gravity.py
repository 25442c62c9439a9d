#!/usr/bin/env python3
"""Gravity compensation of the one-DOF rig, the controller written in Python (docs/python.md).

The simulated rig is peha's (``peha.Rig``: the same plant ``peha run`` drives); the controller is
here: a low-passed finite-difference velocity, the nominal gravity torque
``tau = g (m_link l_com + m_payload l_payload) cos(theta)`` and peha's macro-mini allocation
(``peha.Allocator``) turning it into two pressures and a motor torque. No position feedback.

It runs E1's hold for each payload: the hand holds the link for 2 s while compensation starts,
lets go, and nobody touches the link until the finger's first push (6 s). It prints the angle at
the release and the drift after it (E1's definitions) and, with ``--compare out/<run>/summary.csv``
of ``peha run --config configs/e1_one_dof.yaml``, the same figures of the C++ run beside them.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/e1_python_gravity.py \
        --compare out/latest/summary.csv --plot out/e1_python.png
"""

from __future__ import annotations

import argparse
import csv
import math
import pathlib
import sys

import numpy as np

import peha

ROOT = pathlib.Path(__file__).resolve().parents[1]


class GravityCompensation:
    """E1's controller (control/one_dof_gravity.cpp) in Python: sensors in, command out."""

    def __init__(self, rig: peha.Rig):
        self.allocator = peha.Allocator(rig.joint, rig.allocation)
        self.gravity = rig.gravity
        self.cutoff_Hz = rig.velocity_cutoff_Hz
        self.period_s = rig.allocation.period_s
        self.velocity_radps = 0.0
        self.previous_angle = None
        self.last_time = None

    def update(self, s: dict) -> dict:
        angle, t = float(s["angle_rad"][0]), s["time_s"]
        dt = 0.0 if self.last_time is None else t - self.last_time
        self.last_time = t
        if dt > 0:  # the first sample starts the clock, the second the difference
            if self.previous_angle is None:
                self.previous_angle, self.velocity_radps = angle, 0.0
            else:
                raw = (angle - self.previous_angle) / dt
                self.previous_angle = angle
                self.velocity_radps += (1.0 - math.exp(-2.0 * math.pi * self.cutoff_Hz * dt)) * (raw - self.velocity_radps)
        tau = float(peha.rig_gravity_torque(self.gravity, angle))
        out = self.allocator.step(tau, angle, self.velocity_radps, float(s["agonist_loadcell_N"][0]),
                                  float(s["antagonist_loadcell_N"][0]), float(s["agonist_pressure_Pa"][0]),
                                  float(s["antagonist_pressure_Pa"][0]), dt if dt > 0 else self.period_s)
        out["tau_desired_Nm"] = tau
        return out


def run_hold(scenario, case: str, seconds: float | None = None) -> dict:
    """Runs the case's start (hold, release, no touch) under the Python controller; per-cycle arrays."""
    rig = peha.Rig(str(scenario), case=case)
    pushes = rig.pushes
    hold = pushes[0]
    if seconds is None:  # up to the last sample before the next push begins (its first sample has the finger on)
        steps = int(round(pushes[1]["start_s"] / rig.period_s)) - 1
    else:
        steps = int(round(seconds / rig.period_s))
    ctl = GravityCompensation(rig)
    log = {k: np.empty(steps + 1) for k in ("t_s", "angle_deg", "finger_N", "tau_desired_Nm", "tau_motor_Nm",
                                            "F_agonist_N", "F_antagonist_N", "p_agonist_MPa", "p_antagonist_MPa")}
    for k in range(steps + 1):
        s = rig.read()
        cmd = ctl.update(s)
        truth = rig.sampled_truth()
        rig.write(cmd["agonist_pressure_Pa"], cmd["antagonist_pressure_Pa"], cmd["tau_motor_cmd_Nm"])
        for key, v in (("t_s", s["time_s"]), ("angle_deg", math.degrees(truth["angle_rad"])),
                       ("finger_N", truth["finger_force_N"]), ("tau_desired_Nm", cmd["tau_desired_Nm"]),
                       ("tau_motor_Nm", cmd["tau_motor_cmd_Nm"]), ("F_agonist_N", truth["agonist_force_N"]),
                       ("F_antagonist_N", truth["antagonist_force_N"]), ("p_agonist_MPa", truth["agonist_pressure_Pa"] * 1e-6),
                       ("p_antagonist_MPa", truth["antagonist_pressure_Pa"] * 1e-6)):
            log[key][k] = v
    release_s = hold["start_s"] + hold["duration_s"]
    k0 = int(round(release_s / rig.period_s))
    k1 = min(k0 + int(round(rig.drift_window_s / rig.period_s)), steps)
    # E1's figures: the window stops at the end of the run or (here) before the next push.
    log["case"] = case
    log["release_s"] = release_s
    log["angle_at_release_deg"] = log["angle_deg"][k0]
    log["drift_deg"] = log["angle_deg"][k1] - log["angle_deg"][k0]
    log["max_excursion_deg"] = float(np.max(np.abs(log["angle_deg"][k0:k1 + 1] - log["angle_deg"][k0])))
    return log


def read_summary(path) -> dict:
    """{(case, release): row} of a `peha run` summary.csv."""
    with open(path, newline="") as f:
        return {(r["case"], r["release"]): r for r in csv.DictReader(f)}


def plot(runs: list[dict], path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, len(runs), figsize=(5 * len(runs), 8), sharex=True, squeeze=False)
    for c, r in enumerate(runs):
        a = axes[:, c]
        a[0].plot(r["t_s"], r["angle_deg"], label="angle (plant)")
        a[0].axvline(r["release_s"], color="grey", ls=":", label="release")
        a[0].set_ylabel("angle / deg")
        a[0].set_title(f"{r['case']}: Python controller")
        a[0].legend(fontsize=8)
        a[1].plot(r["t_s"], r["tau_desired_Nm"], label="desired")
        a[1].plot(r["t_s"], r["tau_motor_Nm"], label="motor")
        a[1].plot(r["t_s"], r["F_agonist_N"] / 100, label="agonist force / 100 N")
        a[1].set_ylabel("torque / Nm")
        a[1].legend(fontsize=8)
        a[2].plot(r["t_s"], r["p_agonist_MPa"], label="agonist")
        a[2].plot(r["t_s"], r["p_antagonist_MPa"], label="antagonist")
        a[2].set_ylabel("pressure / MPa")
        a[2].set_xlabel("t / s")
        a[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "e1_one_dof.yaml"))
    ap.add_argument("--case", action="append", help="case(s) to run (default: every case)")
    ap.add_argument("--compare", help="summary.csv of `peha run` of the same scenario")
    ap.add_argument("--plot", help="PNG to write")
    args = ap.parse_args(argv)
    cases = args.case or peha.Rig(args.config).cases
    runs = [run_hold(args.config, c) for c in cases]
    reference = read_summary(args.compare) if args.compare else {}
    print(f"{'case':<16}{'release':<10}{'angle/deg':>10}{'drift/deg':>10}{'excurs/deg':>11}   C++ (peha run): angle, drift")
    worst = 0.0
    for r in runs:
        line = f"{r['case']:<16}{'hold':<10}{r['angle_at_release_deg']:>10.3f}{r['drift_deg']:>10.4f}{r['max_excursion_deg']:>11.4f}"
        ref = reference.get((r["case"], "hold"))
        if ref:
            a, d = float(ref["angle_at_release_deg"]), float(ref["drift_deg"])
            worst = max(worst, abs(a - r["angle_at_release_deg"]), abs(d - r["drift_deg"]))
            line += f"   {a:.3f}, {d:.4f}"
        print(line)
    if reference:
        print(f"largest difference to the C++ run: {worst:.2e} deg")
    if args.plot:
        plot(runs, args.plot)
        print(f"written: {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
