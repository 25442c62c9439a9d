#include "peha/sim/valve.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace peha::sim {
namespace {

ValveParams valve_params() {
  ValveParams p;
  p.dead_time_s = 0.005;
  p.lag_s = 0.03;
  p.rate_limit_Pa_per_s = 4e6;
  p.supply_pressure_Pa = 0.8e6;
  return p;
}

// A step is invisible for the dead time (5 ms = 10 steps of 0.5 ms), then rises.
TEST(Valve, StepWaitsForTheDeadTime) {
  Valve v(valve_params(), 0.0005);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(v.step(0.4e6), 0.0) << k;
  EXPECT_GT(v.step(0.4e6), 0.0);
}

// The set point moves at most 4 MPa/s: a 0.4 MPa step needs 100 ms of ramp, so after dead time +
// 50 ms the set point is at 0.2 MPa and the lagging chamber pressure below it.
TEST(Valve, RateLimitAndLagShapeTheStep) {
  Valve v(valve_params(), 0.0005);
  double p = 0.0;
  for (int k = 0; k < 10 + 100; ++k) p = v.step(0.4e6);
  EXPECT_LT(p, 0.2e6);
  EXPECT_GT(p, 0.1e6);
  // Long after: the first-order lag has settled (e^-30 of the step is left).
  for (int k = 0; k < 2000; ++k) p = v.step(0.4e6);
  EXPECT_NEAR(p, 0.4e6, 1.0);
}

TEST(Valve, NeverExceedsSupplyAndVentsOnInvalidCommand) {
  Valve v(valve_params(), 0.0005);
  double p = 0.0;
  for (int k = 0; k < 4000; ++k) p = v.step(5e6);
  EXPECT_NEAR(p, 0.8e6, 1.0);
  EXPECT_LE(p, 0.8e6);
  for (int k = 0; k < 4000; ++k) p = v.step(std::numeric_limits<double>::quiet_NaN());
  EXPECT_NEAR(p, 0.0, 1.0);
  EXPECT_GE(p, 0.0);
}

}  // namespace
}  // namespace peha::sim
