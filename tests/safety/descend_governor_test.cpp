// The descend governor of one joint (safety::govern_descent, docs/safety.md "descend"): what it
// commands from a sample, run on its own against a muscle that makes less force than its model says.
#include "peha/safety/descend_governor.hpp"
#include "peha/models/units.hpp"

#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace peha::safety {
namespace {

constexpr double kPeriod_s = 1e-3;

DescendGovernorModel arm_like_model(double trim_rate_per_s) {
  DescendGovernorModel m;
  m.speed_radps = models::deg_to_rad(11.5);
  m.force_rate_N_per_s = 150.0;
  m.gain_N_per_radps = 600.0;
  m.floor_fraction = 0.5;
  m.force_slew_N_per_s = 5000.0;
  m.damping_Nms_per_rad = 5.0;
  m.stop_margin_rad = models::deg_to_rad(5.0);
  m.lift_speed_radps = m.speed_radps;
  m.lifted_bleed_fraction = 0.2;
  m.trim_rate_per_s = trim_rate_per_s;
  m.period_s = kPeriod_s;
  return m;
}

/// The joint held still by something (stiction, a hand) for `seconds`, its agonist carrying, each
/// muscle making `plant_share` x the force its model gives at the commanded pressure (the model's
/// error where the governor works: low pressure, long contraction). Returns the agonist's force as
/// the plant makes it at the end.
double held_plant_force_N(const DescendGovernorModel& model, double plant_share, bool cells_trusted, double seconds) {
  const models::JointModel joint = testing::rig_joint();
  io::JointCommand held;
  held.agonist_pressure_Pa = 0.15e6;  // ~600 N: its trimmed command stays under the 2000 N ceiling
  held.antagonist_pressure_Pa = 0.1e6;
  DescentSample sample;
  sample.angle_rad = 0.3;
  sample.min_angle_rad = -0.8;
  sample.max_angle_rad = 0.8;
  DescendGovernorData g;
  double plant_N[2] = {0, 0};
  for (int k = 0; k < static_cast<int>(seconds / kPeriod_s); ++k) {
    if (cells_trusted) sample.measured_N = {plant_N[0], plant_N[1]};
    govern_descent(model, joint, held, sample, g);
    const models::MuscleModel* mm[2] = {&joint.agonist, &joint.antagonist};
    for (int m = 0; m < 2; ++m) {
      const double eps = models::rigid_contraction(*mm[m], joint.pulley_radius_m, m == 0 ? +1 : -1, sample.angle_rad);
      plant_N[m] = plant_share * models::forward_force_N(mm[m]->pam, g.pressure_Pa[static_cast<std::size_t>(m)], eps);
    }
  }
  EXPECT_EQ(g.carrying, 0);
  return plant_N[0];
}

// Trusted load cells trim each muscle's force to the governor's: a muscle making 60 % of its model's
// force still carries the governor's force within 2 %; untrusted (the joint's own fault may be its
// cells), the pressure model alone leaves it at 60 %.
TEST(DescendGovernor, TrustedLoadCellsTrimTheForceTheModelOverstates) {
  DescendGovernorModel model = arm_like_model(5.0);
  model.force_rate_N_per_s = 1e-3;  // a force that stays (held still, the governor bleeds it: a ramp the trim lags)
  const double exact_N = held_plant_force_N(model, 1.0, true, 2.0);
  const double trimmed_N = held_plant_force_N(model, 0.6, true, 2.0);
  const double model_only_N = held_plant_force_N(model, 0.6, false, 2.0);
  EXPECT_NEAR(trimmed_N, exact_N, 0.02 * exact_N);
  EXPECT_NEAR(model_only_N, 0.6 * exact_N, 0.02 * exact_N);
  model.trim_rate_per_s = 0.0;
  EXPECT_NEAR(held_plant_force_N(model, 0.6, true, 2.0), 0.6 * exact_N, 0.02 * exact_N);  // the trim is what carries it
}

// Held still after an operator lifted the joint, the force is bled at lifted_bleed_fraction of the
// rate: the operator may still hold it, and letting go must not drop it onto a bled force.
TEST(DescendGovernor, HeldAfterAnOperatorsLiftTheForceIsBledSlower) {
  const models::JointModel joint = testing::rig_joint();
  io::JointCommand held;
  held.agonist_pressure_Pa = 0.3e6;
  held.antagonist_pressure_Pa = 0.1e6;
  auto bled_N = [&](double lifted_bleed_fraction) {
    DescendGovernorModel model = arm_like_model(0.0);
    model.lifted_bleed_fraction = lifted_bleed_fraction;
    DescentSample sample;
    sample.min_angle_rad = -0.8;
    sample.max_angle_rad = 0.8;
    DescendGovernorData g;
    sample.angle_rad = 0.0;
    govern_descent(model, joint, held, sample, g);  // held: the balance
    const double start_N = g.command_N;
    sample.speed_radps = 0.6;  // lifted by a hand for 0.3 s
    for (int k = 0; k < 300; ++k) sample.angle_rad += sample.speed_radps * kPeriod_s, govern_descent(model, joint, held, sample, g);
    EXPECT_TRUE(g.lifted);
    EXPECT_NEAR(g.command_N, start_N, 1.0);  // kept while lifted
    sample.speed_radps = 0.0;  // held up there for 1 s
    for (int k = 0; k < 1000; ++k) govern_descent(model, joint, held, sample, g);
    return start_N - g.command_N;
  };
  const double slow_N = bled_N(0.2), full_N = bled_N(1.0);
  EXPECT_NEAR(full_N, 150.0, 5.0);  // force_rate_N_per_s for 1 s
  EXPECT_NEAR(slow_N, 30.0, 5.0);
}

}  // namespace
}  // namespace peha::safety
