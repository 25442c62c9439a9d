#!/usr/bin/env python3
"""Gravity compensation of the one-DOF rig, the controller written in Python (docs/python.md).

The simulated rig is peha's (``peha.Rig``: the same plant ``peha run`` drives); the controller is
here: a low-passed finite-difference velocity, the nominal gravity torque
``tau = g (m_link l_com + m_payload l_payload) cos(theta)`` and peha's macro-mini allocation
(``peha.Allocator``) turning it into two pressures and a motor torque. No position feedback.

It runs E1's hold for each payload: the hand holds the link for 2 s while compensation starts,
lets go, and nobody touches the link until the finger's first push (6 s). It prints the angle at
the release, the drift and the max excursion after it (E1's definitions) and, with ``--compare
out/<run>`` of ``peha run --config configs/e1_one_dof.yaml``, the same figures from the C++ run's
log beside them.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/e1_python_gravity.py \
        --compare out/latest --plot out/e1_python.png
"""

from __future__ import annotations

import argparse
import math
import pathlib
import re
import sys

import numpy as np

import peha

ROOT = pathlib.Path(__file__).resolve().parents[1]


class GravityCompensation:
    """E1's controller (control/one_dof_gravity.cpp) in Python: sensors in, command out.

    Without the shipped controller's start-up tare (vent, average the load cells, refill: it needs the
    limits stage, which this loop does not run); it matches the C++ controller with tare_s: 0."""

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
    log["case"] = case
    log["drift_window_s"] = rig.drift_window_s
    log["release_s"] = hold["start_s"] + hold["duration_s"]
    log.update(hold_figures(log["angle_deg"], log["release_s"], rig.period_s, rig.drift_window_s, steps))
    return log


def hold_figures(angle_deg, release_s, period_s, window_s, last_k) -> dict:
    """E1's figures of a release: angle at the release sample, drift and max excursion over the window
    after it, which ends at `last_k` (the last sample before the next push, or of the run)."""
    k0 = int(round(release_s / period_s))
    k1 = min(k0 + int(round(window_s / period_s)), last_k)
    return {"angle_at_release_deg": float(angle_deg[k0]), "drift_deg": float(angle_deg[k1] - angle_deg[k0]),
            "max_excursion_deg": float(np.max(np.abs(angle_deg[k0:k1 + 1] - angle_deg[k0])))}


def cpp_hold_figures(run_dir, r: dict) -> dict:
    """The same figures from the C++ run's log (`peha run`, plant angle at 9 digits) of r's case."""
    log = peha.read_log(pathlib.Path(run_dir) / f"e1_{r['case']}.csv")
    period = log["t_s"][1] - log["t_s"][0]
    return hold_figures(np.degrees(log["plant_angle_rad"]), r["release_s"], period, r["drift_window_s"], r["t_s"].size - 1)


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


def cpp_tare_s(run_dir: str) -> float:
    """The start-up tare of the C++ run (its config.yaml's loadcell_check.tare_s; 0 when absent)."""
    config = pathlib.Path(run_dir) / "config.yaml"
    found = re.search(r"loadcell_check:.*?\btare_s:\s*([0-9.]+)", config.read_text()) if config.is_file() else None
    return float(found.group(1)) if found else 0.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "e1_one_dof.yaml"))
    ap.add_argument("--case", action="append", help="case(s) to run (default: every case)")
    ap.add_argument("--compare", help="run directory of `peha run` of the same scenario (out/<run>)")
    ap.add_argument("--plot", help="PNG to write")
    args = ap.parse_args(argv)
    cases = args.case or peha.Rig(args.config).cases
    runs = [run_hold(args.config, c) for c in cases]
    print(f"{'case':<16}{'release':<10}{'angle/deg':>10}{'drift/deg':>10}{'excurs/deg':>11}"
          + ("   C++ run's log: angle, drift, excursion" if args.compare else ""))
    worst = {"angle": 0.0, "drift": 0.0}
    for r in runs:
        line = f"{r['case']:<16}{'hold':<10}{r['angle_at_release_deg']:>10.4f}{r['drift_deg']:>10.4f}{r['max_excursion_deg']:>11.4f}"
        if args.compare:
            c = cpp_hold_figures(args.compare, r)
            worst["angle"] = max(worst["angle"], abs(c["angle_at_release_deg"] - r["angle_at_release_deg"]))
            worst["drift"] = max([worst["drift"]] + [abs(c[k] - r[k]) for k in ("drift_deg", "max_excursion_deg")])
            line += f"   {c['angle_at_release_deg']:.4f}, {c['drift_deg']:.4f}, {c['max_excursion_deg']:.4f}"
        print(line)
    if args.compare:
        print(f"largest difference to the C++ run: angle {worst['angle']:.1e} deg, drift and excursion "
              f"{worst['drift']:.1e} deg (its log has 9 significant digits)")
        tare_s = cpp_tare_s(args.compare)
        if tare_s > 0:
            print(f"  the C++ run vented, tared ({tare_s:g} s) and refilled at start-up, which this loop does not:"
                  " its angles differ by that start-up; with tare_s: 0 they agree to the log's digits")
    if args.plot:
        plot(runs, args.plot)
        print(f"written: {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
