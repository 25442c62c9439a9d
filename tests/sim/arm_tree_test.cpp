// The rigid-body model as a kinematic tree (two arms on one base): our kinematics, gravity,
// inverse dynamics and gravity regressor against MuJoCo's on the MJCF arm_mjcf writes for the same
// tree, and the tree's bookkeeping (parents, what moves what, rejected orders).

#include "peha/models/arm.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/sim/arm_mjcf.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <random>

namespace peha::sim {
namespace {

using models::ArmBody;
using models::ArmJoint;
using models::ArmModel;

ArmBody body(const std::string& name, int joint, double mass_kg, const Eigen::Vector3d& com_m, double k_m) {
  // A rod-like inertia with a small off-diagonal term, so the MJCF writer's diagonalisation is used.
  Eigen::Matrix3d I = mass_kg * k_m * k_m * Eigen::Vector3d(0.3, 1.0, 1.1).asDiagonal();
  I(0, 1) = I(1, 0) = 0.05 * mass_kg * k_m * k_m;
  return ArmBody{name, joint, mass_kg, com_m, I};
}

// Two arms on a fixed base, each: shoulder abduction (about +x) and flexion (about -y) at one point,
// elbow flexion, wrist flexion. The right arm's joints are listed first; the left arm's root names
// the world and its elbow names its parent explicitly, out of list order with respect to the right arm.
ArmModel two_arm_tree() {
  ArmModel m;
  const Eigen::Vector3d flex(0, -1, 0), abduct(1, 0, 0);
  auto joint = [](const char* name, Eigen::Vector3d offset, Eigen::Vector3d axis, int parent) {
    ArmJoint j{name, offset, axis, true};
    j.parent = parent;
    return j;
  };
  m.joints = {joint("R_SAA", {0, -0.2, 1.4}, -abduct, models::kWorldParent),
              joint("R_SFE", {0, 0, 0}, flex, models::kPreviousJoint),
              joint("R_EFE", {0.3, 0, 0}, flex, 1),
              joint("R_WFE", {0.26, 0, 0.01}, flex, models::kPreviousJoint),
              joint("L_SAA", {0, 0.2, 1.4}, abduct, models::kWorldParent),
              joint("L_SFE", {0, 0, 0}, flex, 4),
              joint("L_EFE", {0.31, 0, 0}, flex, 5),
              joint("L_WFE", {0.25, 0, -0.01}, flex, 6)};
  m.bodies = {body("r_upper", 1, 3.9, {0.17, 0.01, -0.01}, 0.1), body("r_fore", 2, 2.4, {0.11, 0, 0.01}, 0.08),
              body("r_hand", 3, 0.9, {0.06, 0.01, 0}, 0.03),   body("l_upper", 5, 4.1, {0.16, -0.01, 0.02}, 0.1),
              body("l_fore", 6, 2.2, {0.12, 0.01, 0}, 0.08),   body("l_hand", 7, 1.1, {0.05, -0.02, 0}, 0.03),
              body("l_payload", 7, 0.5, {0.07, 0, 0}, 0.01)};
  return m;
}

struct TreeFixture {
  ArmModel model = two_arm_tree();
  models::ArmData data{model};
  ModelPtr m;
  DataPtr d;
  TreeFixture() {
    ArmMjcfOptions o;
    o.model_name = "two_arm_tree";
    o.default_joint.range_min_rad = -4.0;  // wide ranges: no limit constraint at the random postures
    o.default_joint.range_max_rad = 4.0;
    m = load_arm_mjcf(arm_mjcf(model, o));
    d.reset(mj_makeData(m.get()));
  }
};

TEST(ArmTree, ParentsResolveAndEachJointMovesOnlyItsOwnBranch) {
  const ArmModel m = two_arm_tree();
  EXPECT_EQ(m.parent(0), -1);
  EXPECT_EQ(m.parent(1), 0);
  EXPECT_EQ(m.parent(3), 2);
  EXPECT_EQ(m.parent(4), -1);
  EXPECT_EQ(m.parent(5), 4);
  EXPECT_TRUE(m.moves(0, 3));   // the right shoulder moves the right wrist
  EXPECT_FALSE(m.moves(0, 7));  // ... not the left one
  EXPECT_FALSE(m.moves(3, 0));  // a child never moves its parent
}

TEST(ArmTree, MjcfNestsEachBranchUnderItsParentAndGroupsCoincidentJoints) {
  TreeFixture f;
  ASSERT_EQ(f.m->njnt, 8);
  // Shoulder abduction and flexion share one MuJoCo body (zero offset, only child); the elbow has its own.
  EXPECT_EQ(f.m->jnt_bodyid[0], f.m->jnt_bodyid[1]);
  EXPECT_NE(f.m->jnt_bodyid[1], f.m->jnt_bodyid[2]);
  // The left elbow's body is a child of the left shoulder's body, not of anything on the right.
  const int left_elbow_body = f.m->jnt_bodyid[6];
  EXPECT_EQ(f.m->body_parentid[left_elbow_body], f.m->jnt_bodyid[5]);
  EXPECT_EQ(f.m->body_parentid[f.m->jnt_bodyid[4]], 0);  // the left root hangs on the world
}

// tau = J^T G computed in one backward pass over the tree equals MuJoCo's gravity bias, and the
// recursive Newton-Euler equals mj_inverse, at 200 random states each, to 1e-9 Nm.
TEST(ArmTree, GravityAndInverseDynamicsEqualMujocoOnTwoBranches) {
  TreeFixture f;
  const int n = f.model.dof();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> angle(-2.5, 2.5), rate(-4.0, 4.0), accel(-30.0, 30.0);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::VectorXd q(n), qd(n), qdd(n);
    for (int i = 0; i < n; ++i) {
      q[i] = f.d->qpos[i] = angle(rng);
      f.d->qvel[i] = 0;
    }
    mj_forward(f.m.get(), f.d.get());
    const Eigen::VectorXd tau_g = models::gravity_torque(f.model, f.data, q);
    for (int i = 0; i < n; ++i) ASSERT_NEAR(tau_g[i], f.d->qfrc_bias[i], 1e-9) << "gravity, trial " << trial << " joint " << i;
    for (int i = 0; i < n; ++i) {
      qd[i] = f.d->qvel[i] = rate(rng);
      qdd[i] = f.d->qacc[i] = accel(rng);
    }
    mj_inverse(f.m.get(), f.d.get());
    const Eigen::VectorXd& tau = models::inverse_dynamics(f.model, f.data, q, qd, qdd);
    for (int i = 0; i < n; ++i) ASSERT_NEAR(tau[i], f.d->qfrc_inverse[i], 1e-9) << "inverse, trial " << trial << " joint " << i;
  }
}

// The gravity regressor of the tree: Y(q) theta equals the gravity torque, and a parameter of one
// arm's frame leaves every joint of the other arm untouched (its columns are zero there).
TEST(ArmTree, GravityRegressorKeepsTheBranchesApart) {
  const ArmModel model = two_arm_tree();
  models::ArmData data(model);
  const Eigen::VectorXd theta = models::gravity_parameters(model);
  Eigen::MatrixXd Y(model.dof(), models::gravity_parameter_count(model));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-2.5, 2.5);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::VectorXd q(model.dof());
    for (int i = 0; i < model.dof(); ++i) q[i] = angle(rng);
    models::gravity_regressor(model, data, q, Y);
    const Eigen::VectorXd from_regressor = Y * theta;
    const Eigen::VectorXd tau = models::gravity_torque(model, data, q);
    ASSERT_LT((from_regressor - tau).cwiseAbs().maxCoeff(), 1e-10) << "trial " << trial;
    for (int joint = 0; joint < model.dof(); ++joint) {
      for (int frame = 0; frame < model.dof(); ++frame) {
        if (model.moves(joint, frame)) continue;
        const auto k = models::kGravityParametersPerFrame * frame;
        ASSERT_EQ(Y.block(joint, k, 1, models::kGravityParametersPerFrame).cwiseAbs().maxCoeff(), 0.0)
            << model.joints[static_cast<std::size_t>(frame)].name << " loads " << model.joints[static_cast<std::size_t>(joint)].name;
      }
    }
  }
}

// Cost grows with the tree, not its square: evaluating gravity and inverse dynamics allocates nothing.
TEST(ArmTree, GravityAndInverseDynamicsDoNotAllocate) {
  const ArmModel model = two_arm_tree();
  models::ArmData data(model);
  Eigen::VectorXd q = Eigen::VectorXd::Constant(model.dof(), 0.3), qd = q, qdd = q;
  const std::size_t n = peha::testing::allocations_during([&] {
    models::gravity_torque(model, data, q);
    models::inverse_dynamics(model, data, q, qd, qdd);
  });
  EXPECT_EQ(n, 0u);
}

TEST(ArmTree, RejectsAParentListedAfterItsChildNamingBoth) {
  ArmModel m = two_arm_tree();
  m.joints[2].parent = 5;  // R_EFE under L_SFE, which is listed after it
  try {
    models::ArmData data(m);
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("R_EFE"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("parent 5"), std::string::npos) << e.what();
  }
  EXPECT_THROW(arm_mjcf(m, ArmMjcfOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace peha::sim
