#include "peha/models/arm.hpp"

#include "peha/sim/mujoco_model.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>
#include <string>

namespace peha::models {
namespace {

// A three-link chain with non-parallel axes (shoulder and elbow flexion about -y, then a rotation
// about the forearm's long axis), each link carrying an off-axis centre of mass, written both as an
// ArmModel and as MJCF so the two can be compared.
constexpr const char* kChainXml = R"(
<mujoco model="chain">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="upper" pos="0.1 0.2 1.0">
      <joint name="sfe" type="hinge" axis="0 -1 0"/>
      <inertial pos="0.15 0.01 -0.02" mass="2.1" diaginertia="0.01 0.02 0.02"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="efe" type="hinge" axis="0 -1 0"/>
        <inertial pos="0.12 -0.015 0.01" mass="1.3" diaginertia="0.005 0.01 0.01"/>
        <body name="hand" pos="0.25 0 0.02">
          <joint name="wr" type="hinge" axis="1 0 0"/>
          <inertial pos="0.05 0.03 -0.01" mass="0.6" diaginertia="0.001 0.002 0.002"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>)";

ArmModel chain_model() {
  ArmModel m;
  m.joints = {{"sfe", {0.1, 0.2, 1.0}, {0, -1, 0}, true},
              {"efe", {0.3, 0, 0}, {0, -1, 0}, true},
              {"wr", {0.25, 0, 0.02}, {1, 0, 0}, false}};
  m.bodies = {{"upper", 0, 2.1, {0.15, 0.01, -0.02}, Eigen::Matrix3d::Zero()},
              {"fore", 1, 1.3, {0.12, -0.015, 0.01}, Eigen::Matrix3d::Zero()},
              {"hand", 2, 0.6, {0.05, 0.03, -0.01}, Eigen::Matrix3d::Zero()}};
  return m;
}

sim::ModelPtr load_chain() {
  const auto path = std::filesystem::temp_directory_path() / ("peha_arm_chain_test.xml_" + std::to_string(::getpid()));
  { std::ofstream(path) << kChainXml; }
  sim::ModelPtr m = sim::load_mjcf(path);
  std::filesystem::remove(path);
  return m;
}

// tau = J^T G from our own kinematics equals MuJoCo's gravity bias (qfrc_bias at zero velocity) at
// 200 random postures, to 1e-9 Nm.
TEST(ArmGravity, JacobianTransposeGravityEqualsMujocoBiasAtRandomPostures) {
  const ArmModel model = chain_model();
  ArmData data(model);
  sim::ModelPtr m = load_chain();
  sim::DataPtr d(mj_makeData(m.get()));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::VectorXd q(3);
    for (int i = 0; i < 3; ++i) q[i] = d->qpos[i] = angle(rng);
    mju_zero(d->qvel, m->nv);
    mj_forward(m.get(), d.get());
    const Eigen::VectorXd& tau = gravity_torque(model, data, q);
    for (int i = 0; i < 3; ++i) ASSERT_NEAR(tau[i], d->qfrc_bias[i], 1e-9) << "trial " << trial << " joint " << i;
    // The COM positions agree too (MuJoCo's xipos).
    for (int b = 0; b < 3; ++b) {
      const Eigen::Vector3d c = com_position(model, data, b);
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(c[k], d->xipos[3 * (b + 1) + k], 1e-12);
    }
  }
}

// The COM Jacobian is the derivative of the COM position: central differences agree to 1e-7.
TEST(ArmGravity, ComJacobianMatchesCentralDifferences) {
  const ArmModel model = chain_model();
  ArmData data(model);
  Eigen::VectorXd q(3);
  q << 0.3, -0.7, 1.1;
  const double h = 1e-6;
  for (int b = 0; b < 3; ++b) {
    forward_kinematics(model, data, q);
    com_jacobian(model, data, b);
    const Eigen::MatrixXd J = data.jacobian;
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd qp = q, qm = q;
      qp[k] += h;
      qm[k] -= h;
      forward_kinematics(model, data, qp);
      const Eigen::Vector3d cp = com_position(model, data, b);
      forward_kinematics(model, data, qm);
      const Eigen::Vector3d cm = com_position(model, data, b);
      EXPECT_LT(((cp - cm) / (2 * h) - J.col(k)).norm(), 1e-7) << "body " << b << " joint " << k;
    }
  }
}

// Our recursive Newton-Euler equals MuJoCo's mj_inverse (qfrc_inverse) on the same chain at random
// states, to 1e-9 Nm. The chain's inertias are diagonal in the body frames (MJCF diaginertia).
TEST(ArmInverseDynamics, EqualsMujocoInverseAtRandomStates) {
  ArmModel model = chain_model();
  model.bodies[0].inertia_kgm2 = Eigen::Vector3d(0.01, 0.02, 0.02).asDiagonal();
  model.bodies[1].inertia_kgm2 = Eigen::Vector3d(0.005, 0.01, 0.01).asDiagonal();
  model.bodies[2].inertia_kgm2 = Eigen::Vector3d(0.001, 0.002, 0.002).asDiagonal();
  ArmData data(model);
  sim::ModelPtr m = load_chain();
  sim::DataPtr d(mj_makeData(m.get()));
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-4.0, 4.0), accel(-30.0, 30.0);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::VectorXd q(3), qd(3), qdd(3);
    for (int i = 0; i < 3; ++i) {
      q[i] = d->qpos[i] = angle(rng);
      qd[i] = d->qvel[i] = rate(rng);
      qdd[i] = d->qacc[i] = accel(rng);
    }
    mj_inverse(m.get(), d.get());
    const Eigen::VectorXd& tau = inverse_dynamics(model, data, q, qd, qdd);
    for (int i = 0; i < 3; ++i) ASSERT_NEAR(tau[i], d->qfrc_inverse[i], 1e-9) << "trial " << trial << " joint " << i;
  }
}

// At rest inverse dynamics is gravity compensation: the two code paths agree.
TEST(ArmInverseDynamics, AtRestEqualsGravityCompensation) {
  const ArmModel model = chain_model();
  ArmData data(model);
  Eigen::VectorXd q(3), zero = Eigen::VectorXd::Zero(3);
  q << -0.4, 1.2, 0.7;
  const Eigen::VectorXd tau_id = inverse_dynamics(model, data, q, zero, zero);
  const Eigen::VectorXd tau_g = gravity_torque(model, data, q);
  EXPECT_LT((tau_id - tau_g).norm(), 1e-12);
}

TEST(ArmGravity, ComputesWithoutAllocating) {
  const ArmModel model = chain_model();
  ArmData data(model);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(3, 0.4);
  gravity_torque(model, data, q);
  EXPECT_EQ(testing::allocations_during([&] {
              for (int i = 0; i < 1000; ++i) gravity_torque(model, data, q);
            }),
            0u);
}

}  // namespace
}  // namespace peha::models
