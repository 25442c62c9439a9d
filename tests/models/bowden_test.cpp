#include "peha/models/bowden.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace peha::models {
namespace {

const BowdenParams kCable{0.06, 3.49, 200.0};  // mu, psi = 200 deg, alpha

TEST(Bowden, CommandUnchangedAtRest) {
  EXPECT_DOUBLE_EQ(muscle_force_for_joint_N(kCable, 300.0, 0.0), 300.0);
  EXPECT_DOUBLE_EQ(joint_force_from_loadcell_N(kCable, 300.0, 0.0), 300.0);
}

// Reversing the wire's motion inverts the factor: ratio(v) * ratio(-v) = 1.
TEST(Bowden, CompensationIsSymmetricInWireDirection) {
  for (double v = -0.5; v <= 0.5; v += 0.001) {
    EXPECT_NEAR(muscle_to_joint_ratio(kCable, v) * muscle_to_joint_ratio(kCable, -v), 1.0, 1e-12);
  }
}

// Fast motion reaches the capstan limits exp(+-mu psi); the muscle pulls harder when it shortens.
TEST(Bowden, ReachesCapstanLimitsAtSpeed) {
  const double capstan = std::exp(0.06 * 3.49);
  EXPECT_NEAR(muscle_to_joint_ratio(kCable, 1.0), capstan, 1e-9);
  EXPECT_NEAR(muscle_to_joint_ratio(kCable, -1.0), 1.0 / capstan, 1e-9);
  EXPECT_GT(muscle_force_for_joint_N(kCable, 100.0, 0.05), 100.0);
}

// Continuous and monotone: no step anywhere, in particular none at v = 0. The bound on the step is
// the sigmoid's maximum slope: d ratio/dv <= mu*psi*alpha/2 * exp(mu*psi) ~ 25 per m/s.
TEST(Bowden, ContinuousAndMonotoneThroughZeroVelocity) {
  const double dv = 1e-5;
  const double max_slope = 0.06 * 3.49 * 200.0 / 2.0 * std::exp(0.06 * 3.49);
  double previous = muscle_to_joint_ratio(kCable, -0.2);
  for (double v = -0.2 + dv; v <= 0.2; v += dv) {
    const double r = muscle_to_joint_ratio(kCable, v);
    EXPECT_GE(r, previous);
    EXPECT_LE(r - previous, max_slope * dv * 1.0001);
    previous = r;
  }
}

TEST(Bowden, LoadCellInverseUndoesCompensation) {
  for (double v : {-0.3, -0.01, 0.0, 0.002, 0.4}) {
    const double muscle = muscle_force_for_joint_N(kCable, 250.0, v);
    EXPECT_NEAR(joint_force_from_loadcell_N(kCable, muscle, v), 250.0, 1e-9);
  }
}

}  // namespace
}  // namespace peha::models
