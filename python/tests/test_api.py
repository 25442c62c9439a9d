"""A user's own controller from Python (peha.Exoskeleton.control, docs/user-controller.md)."""
import math

import numpy as np
import pytest

import peha
from conftest import ARM


def pd(exo, stiffness, move_deg=0.0, jump=False):
    """A PD + gravity around where the start-up left the arm; the target moves by move_deg from 4 s (1 s ramp, or at once)."""
    target = {}

    def controller(s):
        if not target and not s["starting"]:
            target["q"] = s["angle_rad"].copy()
        tau = s["gravity_torque_Nm"].copy()
        if target:
            progress = (1.0 if s["time_s"] >= 4.0 else 0.0) if jump else min(max(s["time_s"] - 4.0, 0.0), 1.0)
            goal = target["q"] + math.radians(move_deg) * 0.5 * (1.0 - math.cos(math.pi * progress))
            tau += stiffness * (goal - s["angle_rad"]) - 0.1 * stiffness * s["velocity_radps"]
        return tau

    return controller


def test_a_python_pd_holds_the_arm_within_every_limit():
    exo = peha.Exoskeleton(str(ARM))
    assert exo.joint_names == ["R_SFE", "R_EFE", "R_WFE"]
    r = exo.control(pd(exo, 30.0, move_deg=10.0), 6.0)
    assert r.passed, r.failures
    assert r.cycles == 6001
    assert r.faults == 0


def test_a_target_that_jumps_fails_the_wire_tension_figure():
    # A stiff PD whose target jumps 30 deg: the shoulder's wire goes slack (tests/api/exoskeleton_test.cpp).
    r = peha.Exoskeleton(str(ARM)).control(pd(None, 100.0, move_deg=30.0, jump=True), 6.0)
    assert not r.passed
    assert "lowest wire tension" in r.failures


def test_none_ends_the_run_and_an_exception_is_raised_after_it():
    exo = peha.Exoskeleton(str(ARM))
    r = exo.control(lambda s: None if s["time_s"] >= 0.5 else s["gravity_torque_Nm"], 5.0)
    assert abs(r.cycles - 501) <= 1

    def broken(s):
        raise RuntimeError("my controller broke")

    with pytest.raises(RuntimeError, match="my controller broke"):
        exo.control(broken, 1.0)
    with pytest.raises(ValueError, match="returned 2 torques; the arm has 3 joints"):
        exo.control(lambda s: np.zeros(2), 1.0)
    with pytest.raises(ValueError, match="runs on the simulator"):
        peha.Exoskeleton(str(ARM), "udp://127.0.0.1:9")
