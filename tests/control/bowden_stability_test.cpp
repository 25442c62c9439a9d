// Bowden compensation that cannot destabilise (docs/models.md, "Compensation that cannot
// destabilise"): E1 stays stable for plant cable friction (kinetic and static) from 0 to twice the
// nominal plant's while the controller keeps its nominal model; the old, full compensation swings
// from stop to stop on a cable without friction.
#include "e1_figures.hpp"

#include <gtest/gtest.h>

#include <iostream>

namespace peha {
namespace {

constexpr double kPretension_N = 60.0;

class CableFriction : public ::testing::TestWithParam<double> {};

// Thresholds (issue 10): the link comes to rest after every release (no limit cycle) and never
// runs toward a stop (|angle| <= 40 deg; the pushes go to +25 and -15 deg); the torque the
// friction and the stops hold at rest is <= 5 % of the gravity torque; both wires keep >= 50 % of
// the pretension after the start-up hold. Every plant cable friction from x0.25 to x2.
TEST_P(CableFriction, E1StaysStableWithTheNominalModel) {
  const double factor = GetParam();
  experiments::E1Scenario s = testing::e1_scenario();
  testing::scale_plant_cable_friction(s, factor);
  for (const experiments::E1Case& c : s.cases) {
    const testing::E1Figures f = testing::run_e1_figures(s, c);
    std::cout << "cable friction x" << factor << ", " << c.name << ": " << testing::describe(f) << "\n";
    EXPECT_TRUE(f.settled) << c.name;
    EXPECT_LE(f.max_abs_angle_deg, 40.0) << c.name;
    EXPECT_LE(f.worst_static_error_pct, 5.0) << c.name;
    EXPECT_GE(f.min_tension_after_start_N, 0.5 * kPretension_N) << c.name;
  }
}

INSTANTIATE_TEST_SUITE_P(QuarterToTwiceNominal, CableFriction, ::testing::Values(0.25, 0.5, 1.0, 1.5, 2.0));

// Without any cable friction nothing holds the link against the controller's gravity model, which
// is 2.2-2.8 % high (pulley radius 0.035 vs 0.0355 m, link moment 0.105 vs 0.090 kg m): it must
// drift, with no position feedback (docs/models.md). What the design guarantees is that it only
// creeps: no swing back of more than 0.5 deg in any release window (no limit cycle), never faster
// than 0.15 rad/s (the old compensation reaches 3 rad/s), and both wires taut.
TEST(BowdenCompensation, WithoutCableFrictionTheLinkOnlyCreeps) {
  experiments::E1Scenario s = testing::e1_scenario();
  testing::scale_plant_cable_friction(s, 0.0);
  for (const experiments::E1Case& c : s.cases) {
    const testing::E1Figures f = testing::run_e1_figures(s, c);
    std::cout << "cable friction x0, " << c.name << ": " << testing::describe(f) << "\n";
    EXPECT_LE(f.worst_swing_back_deg, 0.5) << c.name;
    EXPECT_LE(f.max_speed_after_release_radps, 0.15) << c.name;
    EXPECT_GE(f.min_tension_after_start_N, 0.5 * kPretension_N) << c.name;
  }
}

// The old design (the controller's full cable friction compensated, sure fraction 1, no motor
// damping) is positive velocity feedback on a cable with less friction than the model: without
// cable friction the link swings from stop to stop, so the figures above can fail.
TEST(BowdenCompensation, OldFullCompensationSwingsWithoutCableFriction) {
  experiments::E1Scenario s = testing::e1_scenario();
  testing::scale_plant_cable_friction(s, 0.0);
  s.controller.allocation.sure_cable_friction_fraction = 1.0;
  s.controller.allocation.motor_damping_Nms_per_rad = 0.0;
  // This measures the unprotected controller: the supervisor's speed check would stop the swing.
  s.limits.test_overrides.unchecked = ~0u;  // an unprotected controller, measured
  const experiments::E1Case& c = s.cases.back();  // 5.0 kg
  const testing::E1Figures f = testing::run_e1_figures(s, c);
  std::cout << "old compensation, cable friction x0, " << c.name << ": " << testing::describe(f) << "\n";
  EXPECT_GT(f.worst_swing_back_deg, 10.0);
  EXPECT_GT(f.max_speed_after_release_radps, 1.0);
  EXPECT_FALSE(f.settled);
}

}  // namespace
}  // namespace peha
