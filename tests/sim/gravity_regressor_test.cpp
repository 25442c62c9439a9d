// The gravity regressor tau_g(q) = Y(q) theta (models/gravity_parameters.hpp) cross-checked against
// the controller's J^T G and against MuJoCo's gravity (qfrc_bias at zero velocity) of the same arm.
#include "../support/alloc_counter.hpp"
#include "peha/models/exoskeleton.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/arm_mjcf.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace peha::models {
namespace {


BodyConfig shipped_arm() { return read_body(config::Document::load_file(PEHA_SOURCE_DIR "/configs/arm/right_arm_body.yaml")); }

std::vector<Eigen::VectorXd> postures() {
  std::vector<Eigen::VectorXd> out;
  for (const auto& a : std::vector<std::vector<double>>{{0, 0, 0, 0, 0},       {-45, 30, -10, 0, 0}, {-90, 90, 15, 0, 0},
                                                        {20, 60, -17, 0, 0},   {45, 120, 30, 0, 0},  {-100, 5, 0, 0, 0},
                                                        {-30, 100, 10, 20, -15}}) {
    Eigen::VectorXd q(5);
    for (int i = 0; i < 5; ++i) q[i] = deg_to_rad(a[static_cast<std::size_t>(i)]);
    out.push_back(q);
  }
  return out;
}

// Y(q) theta of the model's own bodies is the controller's J^T G, on every joint (1e-12 Nm: the
// same sums in another order).
TEST(GravityRegressor, EqualsTheControllersJacobianTransposeGravity) {
  const ArmModel arm = shipped_arm().controller.model();
  ArmData data(arm);
  Eigen::MatrixXd Y(arm.dof(), gravity_parameter_count(arm));
  const Eigen::VectorXd theta = gravity_parameters(arm);
  for (const Eigen::VectorXd& q : postures()) {
    gravity_regressor(arm, data, q, Y);
    const Eigen::VectorXd tau = Y * theta;
    EXPECT_LT((tau - gravity_torque(arm, data, q)).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// Cross-check against MuJoCo: the plant's arm (its own, heavier bodies) as MJCF, qfrc_bias at zero
// velocity on 7 postures (wrist and passive joints included), within 1e-9 Nm of Y(q) theta_plant.
// A sign or frame error in the regressor would show as whole newton-metres at the shoulder.
TEST(GravityRegressor, MatchesMujocosGravityOfThePlantArm) {
  const ArmModel plant = shipped_arm().plant.model();
  const sim::ModelPtr m = sim::load_arm_mjcf(sim::arm_mjcf(plant, sim::ArmMjcfOptions{}));
  const sim::DataPtr d(mj_makeData(m.get()));
  ArmData data(plant);
  Eigen::MatrixXd Y(plant.dof(), gravity_parameter_count(plant));
  const Eigen::VectorXd theta = gravity_parameters(plant);
  for (const Eigen::VectorXd& q : postures()) {
    for (int i = 0; i < m->nq; ++i) d->qpos[i] = q[i];
    for (int i = 0; i < m->nv; ++i) d->qvel[i] = 0;
    mj_forward(m.get(), d.get());
    gravity_regressor(plant, data, q, Y);
    const Eigen::VectorXd tau = Y * theta;
    for (int i = 0; i < plant.dof(); ++i) EXPECT_NEAR(tau[i], d->qfrc_bias[i], 1e-9) << "joint " << i << " at q " << q.transpose() * kDegPerRad;
  }
}

// The regressor runs in the loop's style: sized once, then no heap allocation per evaluation.
TEST(GravityRegressor, EvaluationDoesNotAllocate) {
  const ArmModel arm = shipped_arm().controller.model();
  ArmData data(arm);
  Eigen::MatrixXd Y(arm.dof(), gravity_parameter_count(arm));
  const std::vector<Eigen::VectorXd> qs = postures();
  const std::size_t n = peha::testing::allocations_during([&] {
    for (const Eigen::VectorXd& q : qs) gravity_regressor(arm, data, q, Y);
  });
  EXPECT_EQ(n, 0u);
}

// The arm rebuilt from parameters (one body per frame) has exactly those parameters' gravity, and a
// frame with a first moment but no mass is refused.
TEST(GravityRegressor, ArmFromParametersHasTheirGravity) {
  const ArmModel arm = shipped_arm().controller.model();
  Eigen::VectorXd theta = gravity_parameters(arm);
  theta[0] *= 1.1;   // shoulder frame 10 % heavier
  theta[5] += 0.05;  // elbow frame's h_x + 0.05 kg m
  const ArmModel rebuilt = with_gravity_parameters(arm, theta);
  ArmData a(arm), b(rebuilt);
  Eigen::MatrixXd Y(arm.dof(), gravity_parameter_count(arm));
  for (const Eigen::VectorXd& q : postures()) {
    gravity_regressor(arm, a, q, Y);
    EXPECT_LT((Y * theta - gravity_torque(rebuilt, b, q)).cwiseAbs().maxCoeff(), 1e-12);
  }
  theta[4] = 0.0;
  EXPECT_THROW(with_gravity_parameters(arm, theta), std::invalid_argument);
}

}  // namespace
}  // namespace peha::models
