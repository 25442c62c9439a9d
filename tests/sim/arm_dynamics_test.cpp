// Issue 4's cross-checks on the real right-arm model (exoskeleton + user arm + payload, from
// configs/arm/right_arm_body.yaml): our gravity compensation tau = J^T G equals MuJoCo's own bias force at
// zero velocity, and our inverse dynamics equals mj_inverse, at random postures and states.
#include "peha/models/exoskeleton.hpp"
#include "peha/models/arm.hpp"
#include "peha/sim/arm_mjcf.hpp"

#include <gtest/gtest.h>

#include <random>

namespace peha {
namespace {

struct RightArm {
  models::ArmModel model;
  sim::ModelPtr mj;
};

/// The plant's arm with a 2 kg payload, joints unlocked and undamped so MuJoCo's equations are the
/// pure rigid-body ones our model describes.
RightArm right_arm() {
  const models::BodyConfig cfg =
      models::read_body(config::Document::load_file(PEHA_SOURCE_DIR "/configs/arm/right_arm_body.yaml"));
  models::ExoskeletonSpec setup = cfg.plant;
  setup.payload_kg = 2.0;
  RightArm arm{setup.model(), nullptr};
  sim::ArmMjcfOptions options = sim::exoskeleton_mjcf_options(setup);
  for (sim::ArmMjcfJoint& j : options.joints) {
    j.locked = false;
    j.damping_Nms_per_rad = 0.0;
    j.armature_kgm2 = 0.0;
    j.stiffness_Nm_per_rad = 0.0;
  }
  arm.mj = sim::load_arm_mjcf(sim::arm_mjcf(arm.model, options));
  // Random states leave the joint ranges; mj_inverse would then add limit forces. Compare the pure
  // rigid-body equations: no limits, equalities or contacts.
  arm.mj->opt.disableflags |= mjDSBL_LIMIT | mjDSBL_EQUALITY | mjDSBL_CONTACT;
  return arm;
}

TEST(RightArm, GravityCompensationEqualsMujocoBiasForceAtRandomPostures) {
  RightArm arm = right_arm();
  ASSERT_EQ(arm.mj->nv, arm.model.dof());
  models::ArmData data(arm.model);
  sim::DataPtr d(mj_makeData(arm.mj.get()));
  std::mt19937_64 rng(44);
  std::uniform_real_distribution<double> angle(-1.6, 1.6);
  double worst = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Eigen::VectorXd q(arm.model.dof());
    for (int i = 0; i < q.size(); ++i) q[i] = d->qpos[i] = angle(rng);
    mju_zero(d->qvel, arm.mj->nv);
    mj_forward(arm.mj.get(), d.get());
    const Eigen::VectorXd& tau = models::gravity_torque(arm.model, data, q);
    for (int i = 0; i < q.size(); ++i) worst = std::max(worst, std::abs(tau[i] - d->qfrc_bias[i]));
  }
  EXPECT_LT(worst, 1e-9) << "worst |J^T G - qfrc_bias| over 500 postures, Nm";
}

TEST(RightArm, InverseDynamicsEqualsMujocoInverseAtRandomStates) {
  RightArm arm = right_arm();
  models::ArmData data(arm.model);
  sim::DataPtr d(mj_makeData(arm.mj.get()));
  std::mt19937_64 rng(45);
  std::uniform_real_distribution<double> angle(-1.6, 1.6), rate(-3.0, 3.0), accel(-20.0, 20.0);
  double worst = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const int n = arm.model.dof();
    Eigen::VectorXd q(n), qd(n), qdd(n);
    for (int i = 0; i < n; ++i) {
      q[i] = d->qpos[i] = angle(rng);
      qd[i] = d->qvel[i] = rate(rng);
      qdd[i] = d->qacc[i] = accel(rng);
    }
    mj_inverse(arm.mj.get(), d.get());
    const Eigen::VectorXd& tau = models::inverse_dynamics(arm.model, data, q, qd, qdd);
    for (int i = 0; i < n; ++i) worst = std::max(worst, std::abs(tau[i] - d->qfrc_inverse[i]));
  }
  EXPECT_LT(worst, 1e-9) << "worst |RNEA - mj_inverse| over 500 states, Nm";
}

}  // namespace
}  // namespace peha
