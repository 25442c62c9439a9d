"""The simulated plants from Python against the same plants driven from C++ (peha_py_reference)."""
import sys

import numpy as np

import peha
from conftest import ARM, E1, ROOT

sys.path.insert(0, str(ROOT / "examples"))
from e1_python_gravity import GravityCompensation  # noqa: E402  (the example's controller is the one tested)


def python_e1_controller(rig, steps):
    """E1's controller written in Python (examples/e1_python_gravity.py) on the rig for steps + 1 cycles."""
    ctl = GravityCompensation(rig)
    out = {k: [] for k in ("t", "angle", "truth", "p1", "p2", "motor")}
    for _ in range(steps + 1):
        s = rig.read()
        a = ctl.update(s)
        rig.write(a["agonist_pressure_Pa"], a["antagonist_pressure_Pa"], a["tau_motor_cmd_Nm"])
        for k, v in (("t", s["time_s"]), ("angle", float(s["angle_rad"][0])), ("truth", rig.truth()["angle_rad"]),
                     ("p1", a["agonist_pressure_Pa"]), ("p2", a["antagonist_pressure_Pa"]), ("motor", a["tau_motor_cmd_Nm"])):
            out[k].append(v)
    return {k: np.array(v) for k, v in out.items()}


def test_rig_with_python_controller_matches_cpp_controller(ref):
    rig = peha.Rig(str(E1), case=ref["rig_case"])
    run = python_e1_controller(rig, 3000)
    tol = dict(rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(run["t"], ref["rig_time_s"], **tol)
    np.testing.assert_allclose(run["angle"], ref["rig_angle_rad"], **tol)
    np.testing.assert_allclose(run["truth"], ref["rig_truth_angle_rad"], **tol)
    np.testing.assert_allclose(run["p1"], ref["rig_agonist_pressure_cmd_Pa"], **tol)
    np.testing.assert_allclose(run["p2"], ref["rig_antagonist_pressure_cmd_Pa"], **tol)
    np.testing.assert_allclose(run["motor"], ref["rig_motor_cmd_Nm"], **tol)


def test_rig_reset_repeats_the_run(ref):
    rig = peha.Rig(str(E1), case=ref["rig_case"])
    a = python_e1_controller(rig, 200)
    rig.reset()
    b = python_e1_controller(rig, 200)
    np.testing.assert_array_equal(a["truth"], b["truth"])
    assert rig.payload_kg > 0 and rig.pushes[0]["hold"]


def test_arm_matches_cpp(ref):
    arm = peha.Arm(str(ARM))
    n = len(arm.joint_names)
    q = []
    for _ in range(500):
        s = arm.read()
        q.extend(s["angle_rad"])
        arm.write(np.full(n, 0.3e6), np.full(n, 0.2e6), np.full(n, 0.5))
    np.testing.assert_allclose(q, ref["arm_sim_angle_rad"], rtol=1e-12, atol=1e-12)
    t = arm.truth()
    assert len(t["actuators"]) == n and t["q_rad"].size == arm.arm_model.dof
