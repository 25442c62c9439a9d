#include "peha/safety/limits.hpp"

#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>

namespace peha::safety {
namespace {

// The joint set-up the limits read (the controller's): the rig's, with a 40 N pretension.
const models::JointModel& rig() {
  static const models::JointModel joint = [] {
    models::JointModel j = peha::testing::rig_joint();
    j.pretension_N = 40.0;
    return j;
  }();
  return joint;
}
const JointModels kJoints{&rig()};

LimitsModel rig_limits() {
  LimitsModel m;
  m.joint_count = 1;
  m.period_s = 1e-3;
  m.joints[0].min_angle_rad = -0.8;
  m.joints[0].max_angle_rad = 0.8;
  return m;
}

io::SensorState at_angle(double angle) {
  io::SensorState s;
  s.joint_count = 1;
  s.joints[0].angle_rad = angle;
  return s;
}

// How many random commands the property tests draw: 10^5 in `make test`; `make property` sets
// PEHA_PROPERTY_STEPS=10000000.
int property_steps() {
  const char* env = std::getenv("PEHA_PROPERTY_STEPS");
  if (env == nullptr) return 100000;
  const long n = std::strtol(env, nullptr, 10);
  return n > 0 && n <= 1'000'000'000L ? static_cast<int>(n) : 100000;
}

// No command leaving the limits layer makes the controller's model exceed a muscle's ceiling, go
// below the pretension, exceed the supply, the motor rating, or the pressure rate - for random and
// non-finite commands at random angles (a property test: property_steps() draws).
TEST(Limits, EveryCommandLeavesWithinAllLimits) {
  const LimitsModel model = rig_limits();
  LimitsData data;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> p(-2e6, 3e6), tau(-50.0, 50.0), angle(-0.7, 0.7);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  io::Command prev{};
  const int steps = property_steps();
  std::printf("Limits property: %d random commands\n", steps);
  for (int i = 0; i < steps; ++i) {
    const io::SensorState s = at_angle(angle(rng));
    io::Command c;
    c.joint_count = 1;
    c.joints[0] = {p(rng), p(rng), tau(rng)};
    if (i % 97 == 0) c.joints[0].agonist_pressure_Pa = nan;
    if (i % 89 == 0) c.joints[0].motor_torque_Nm = std::numeric_limits<double>::infinity();
    apply_limits(model, kJoints, data, s, c);
    const io::JointCommand& j = c.joints[0];
    const auto& jm = rig();
    const double r0 = jm.pulley_radius_m;
    const double eps1 = models::rigid_contraction(jm.agonist, r0, +1, s.joints[0].angle_rad);
    const double eps2 = models::rigid_contraction(jm.antagonist, r0, -1, s.joints[0].angle_rad);
    ASSERT_TRUE(std::isfinite(j.agonist_pressure_Pa) && std::isfinite(j.antagonist_pressure_Pa) &&
                std::isfinite(j.motor_torque_Nm));
    ASSERT_LE(j.agonist_pressure_Pa, rig().supply_pressure_Pa);
    ASSERT_LE(models::forward_force_N(jm.agonist.pam, j.agonist_pressure_Pa, eps1), 2000.0 + 1e-6);
    ASSERT_LE(models::forward_force_N(jm.antagonist.pam, j.antagonist_pressure_Pa, eps2), 630.0 + 1e-6);
    ASSERT_LE(std::abs(j.motor_torque_Nm), jm.motor_max_torque_Nm);
    if (i > 0) {
      ASSERT_LE(std::abs(j.motor_torque_Nm - prev.joints[0].motor_torque_Nm), 500.0 * 1e-3 + 1e-12);
    }
    prev = c;
  }
}

// From rest, a settled command keeps the wires at the pretension or above by the model.
TEST(Limits, PressureFloorKeepsPretension) {
  const LimitsModel model = rig_limits();
  LimitsData data;
  const io::SensorState s = at_angle(0.2);
  io::Command c;
  for (int i = 0; i < 2000; ++i) {  // let the rate limit settle
    c.joint_count = 1;
    c.joints[0] = {0.0, 0.0, 0.0};  // asks for slack wires
    apply_limits(model, kJoints, data, s, c);
  }
  const auto& jm = rig();
  const double eps1 = models::rigid_contraction(jm.agonist, jm.pulley_radius_m, +1, 0.2);
  EXPECT_NEAR(models::forward_force_N(jm.agonist.pam, c.joints[0].agonist_pressure_Pa, eps1), 40.0, 1e-6);
  EXPECT_TRUE(data.flags[0] & kPressureLimited);
}

// Past the upper range limit the agonist may not gain pressure and the motor may not push up.
TEST(Limits, BeyondRangeNothingPushesFurtherOut) {
  const LimitsModel model = rig_limits();
  LimitsData data;
  io::Command c;
  c.joint_count = 1;
  c.joints[0] = {0.2e6, 0.2e6, 0.0};
  for (int i = 0; i < 500; ++i) {
    io::Command step = c;
    apply_limits(model, kJoints, data, at_angle(0.0), step);
  }
  const double before = data.previous.joints[0].agonist_pressure_Pa;
  io::Command push{};
  push.joint_count = 1;
  push.joints[0] = {0.6e6, 0.2e6, 2.0};
  apply_limits(model, kJoints, data, at_angle(0.9), push);
  EXPECT_LE(push.joints[0].agonist_pressure_Pa, before);
  EXPECT_LE(push.joints[0].motor_torque_Nm, 0.0);
  EXPECT_TRUE(data.flags[0] & kJointRange);
}

// A pressure residual that varies with contraction and force (a stand-in for the SPGP).
class WavyResidual final : public models::PressureResidual {
 public:
  double pressure_Pa(double eps, double force_N) const noexcept override {
    return 2e4 * std::sin(40.0 * eps) + 10.0 * force_N;
  }
};

// The band a joint reuses while its angle repeats (encoder counts) gives the same commands, bit for
// bit, as computing it every step - also when the joint set-up is swapped for another - and is
// computed only when the contraction or the set-up changes.
TEST(Limits, ReusedPressureBandGivesTheSameCommandsAsComputingItEveryStep) {
  const LimitsModel model = rig_limits();
  models::JointModel with_residual = rig();
  with_residual.agonist.residual = with_residual.antagonist.residual = std::make_shared<WavyResidual>();
  models::JointModel other = with_residual;
  other.pretension_N = 80.0;
  LimitsData reused, fresh;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> p(-0.5e6, 1.2e6), tau(-5.0, 5.0), angle(-0.7, 0.7);
  constexpr int kSteps = 3000, kRepeat = 4;  // each angle held for 4 steps
  double a = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    if (i % kRepeat == 0) a = std::round(angle(rng) * 1e4) / 1e4;
    const JointModels joints{i < kSteps / 2 || i % 2 == 1 ? &with_residual : &other};
    io::Command c;
    c.joint_count = 1;
    c.joints[0] = {p(rng), p(rng), tau(rng)};
    io::Command d = c;
    fresh.bands = {};
    apply_limits(model, joints, reused, at_angle(a), c);
    apply_limits(model, joints, fresh, at_angle(a), d);
    ASSERT_EQ(std::memcmp(&c.joints[0], &d.joints[0], sizeof c.joints[0]), 0) << "step " << i;
    ASSERT_EQ(reused.flags[0], fresh.flags[0]) << "step " << i;
  }
  EXPECT_EQ(fresh.band_evaluations, 2u * kSteps);
  // First half: one new angle per 4 steps (2 bands each); second half: the set-up alternates every step.
  EXPECT_EQ(reused.band_evaluations, 2u * (kSteps / 2 / kRepeat) + 2u * (kSteps / 2));
  EXPECT_GT(fresh.counts[2], 100u);  // the band did clamp (kPressureLimited), so the test compares real bands
}

}  // namespace
}  // namespace peha::safety
