"""Every bound model function against the C++ results (peha_py_reference) to 1e-12."""
import numpy as np
import pytest

import peha
from conftest import ARM, E1

TOL = dict(rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def joint():
    return peha.Rig(str(E1)).joint


def test_tendon_spring_forward_inverse_gain_match_cpp(ref, joint):
    pam = joint.agonist.pam
    P, F, eps = (np.array(ref[k]) for k in ("pressure_Pa", "force_N", "eps"))
    np.testing.assert_allclose(peha.forward_force(pam, P, eps), ref["forward_force"], **TOL)
    supply = ref["supply_pressure_Pa"]
    np.testing.assert_allclose(peha.inverse_pressure(pam, F, eps, supply), ref["inverse_pressure"], **TOL)
    np.testing.assert_array_equal(peha.inverse_status(pam, F, eps, supply), np.array(ref["inverse_status"], dtype=int))
    np.testing.assert_allclose(peha.gain(pam, eps), ref["gain"], **TOL)


def test_scalars_give_floats_and_broadcast(ref, joint):
    pam = joint.agonist.pam
    f = peha.forward_force(pam, ref["pressure_Pa"][100], ref["eps"][100])
    assert isinstance(f, float) and f == ref["forward_force"][100]
    p = peha.inverse_pressure(pam, ref["force_N"][100], ref["eps"][100], ref["supply_pressure_Pa"])
    assert isinstance(p, float) and p == ref["inverse_pressure"][100]
    grid = peha.forward_force(pam, np.array([[2e5], [4e5]]), np.array([0.0, 0.1, 0.2]))
    assert grid.shape == (2, 3)
    assert grid[1, 2] == peha.forward_force(pam, 4e5, 0.2)


def test_inverse_of_forward_is_identity_where_ok(joint):
    pam = joint.agonist.pam
    P = np.linspace(0.1e6, 0.6e6, 11)
    eps = np.full_like(P, 0.05)
    F = peha.forward_force(pam, P, eps)
    np.testing.assert_allclose(peha.inverse_pressure(pam, F, eps), P, rtol=1e-9)
    assert peha.InverseStatus(int(peha.inverse_status(pam, F[3:4], eps[3:4])[0])) == peha.InverseStatus.OK


def test_bowden_match_cpp(ref, joint):
    b = joint.agonist.bowden
    v = np.array(ref["wire_velocity_mps"])
    f = 50.0 + 20.0 * np.arange(v.size)
    np.testing.assert_allclose(peha.muscle_to_joint_ratio(b, v), ref["muscle_to_joint_ratio"], **TOL)
    np.testing.assert_allclose(peha.muscle_force_for_joint(b, f, v), ref["muscle_force_for_joint"], **TOL)
    np.testing.assert_allclose(peha.joint_force_from_loadcell(b, f, v), ref["joint_force_from_loadcell"], **TOL)
    # ratio(v) * ratio(-v) == 1 (bowden.hpp)
    np.testing.assert_allclose(peha.muscle_to_joint_ratio(b, v) * peha.muscle_to_joint_ratio(b, -v), 1.0, rtol=1e-14)


def test_joint_functions_match_cpp(ref, joint):
    v = np.array(ref["wire_velocity_mps"])
    angle = np.array(ref["angle_rad"])
    i = np.arange(v.size)
    f = 50.0 + 20.0 * i
    r0 = joint.pulley_radius_m
    np.testing.assert_allclose(peha.muscle_pressure(joint.agonist, f, 0.02 + 0.002 * i, joint.supply_pressure_Pa),
                               ref["muscle_pressure"], **TOL)
    np.testing.assert_allclose(peha.rigid_contraction(joint.agonist, r0, 1, angle), ref["rigid_contraction_agonist"], **TOL)
    np.testing.assert_allclose(peha.rigid_contraction(joint.antagonist, r0, -1, angle),
                               ref["rigid_contraction_antagonist"], **TOL)
    np.testing.assert_allclose(peha.wire_velocity(r0, -1, v * 10), ref["wire_velocity_antagonist"], **TOL)
    np.testing.assert_allclose(peha.joint_torque(r0, f, 0.5 * f, v * 10), ref["joint_torque"], **TOL)
    assert peha.force_ceiling(joint.antagonist) == ref["force_ceiling_antagonist"]


def test_rig_gravity_torque_matches_cpp(ref):
    rig = peha.Rig(str(E1), case=peha.Rig(str(E1)).cases[-1])
    np.testing.assert_allclose(peha.rig_gravity_torque(rig.gravity, ref["angle_rad"]), ref["rig_gravity_torque"], **TOL)


def test_arm_gravity_and_inverse_dynamics_match_cpp(ref):
    model = peha.ArmModel.from_scenario(str(ARM))
    dof = ref["arm_dof"]
    assert model.dof == dof
    q, qd, qdd = (np.array(ref[k]).reshape(-1, dof) for k in ("arm_q", "arm_qd", "arm_qdd"))
    np.testing.assert_allclose(peha.gravity_torque(model, q), np.reshape(ref["arm_gravity_torque"], (-1, dof)), **TOL)
    np.testing.assert_allclose(peha.inverse_dynamics(model, q, qd, qdd),
                               np.reshape(ref["arm_inverse_dynamics"], (-1, dof)), **TOL)
    one = peha.gravity_torque(model, q[2])
    assert one.shape == (dof,)
    np.testing.assert_allclose(one, np.reshape(ref["arm_gravity_torque"], (-1, dof))[2], **TOL)
    # At rest, inverse dynamics is the gravity torque.
    np.testing.assert_allclose(peha.inverse_dynamics(model, q, 0 * q, 0 * q), peha.gravity_torque(model, q), atol=1e-12)


def test_arm_model_built_in_python():
    m = peha.ArmModel()
    m.joints = [peha.ArmJoint("hinge", [0, 0, 0], [0, 1, 0])]
    m.bodies = [peha.ArmBody("link", 0, 2.0, [0.5, 0, 0])]
    # a 2 kg point at 0.5 m on a horizontal link about y: |tau| = m g l
    assert abs(abs(peha.gravity_torque(m, [0.0])[0]) - 2.0 * 9.81 * 0.5) < 1e-12


def test_bad_shapes_raise():
    model = peha.ArmModel.from_scenario(str(ARM))
    with pytest.raises(ValueError):
        peha.gravity_torque(model, np.zeros(model.dof + 1))
    with pytest.raises(ValueError):
        peha.Rig(str(E1), case="no_such_case")


def test_a_pressure_in_mpa_or_beyond_any_muscle_is_refused(joint):
    pam = joint.agonist.pam
    assert peha.forward_force(pam, 3e5, 0.1) > 500.0  # 0.3 MPa: hundreds of N
    with pytest.raises(ValueError, match="MPa given as Pa"):
        peha.forward_force(pam, 0.3, 0.1)  # was 0.0012 N, silently
    with pytest.raises(ValueError, match="kPa or bar given as Pa"):
        peha.forward_force(pam, np.array([3e5, 3e6]), np.array([0.1, 0.1]))
    with pytest.raises(ValueError, match="supply_pressure_Pa"):
        peha.muscle_pressure(joint.agonist, np.array([500.0]), np.array([0.1]), 0.8)
    assert peha.forward_force(pam, 0.0, 0.1) == 0.0  # vented is a pressure
