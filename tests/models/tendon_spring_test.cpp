#include "peha/models/tendon_spring.hpp"

#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace peha::models {
namespace {

constexpr double kSupply_Pa = 0.8e6;  // the joint's supply: the inverse's ceiling
using peha::testing::dmsp10_nominal;
using peha::testing::dmsp40_nominal;

// Over the operating range (0..0.8 MPa, contraction -0.02..0.2) the inverse of the forward model
// returns the pressure it started from, to 1e-9 relative (closed form vs quadratic root).
TEST(TendonSpring, InverseOfForwardIsIdentityAcrossOperatingRange) {
  for (const TendonSpringParams& p : {dmsp40_nominal(), dmsp10_nominal()}) {
    int checked = 0;
    for (double P = 0.01e6; P < 0.7999e6; P += 0.01e6) {
      for (double eps = -0.02; eps <= 0.2; eps += 0.005) {
        const double F = forward_force_N(p, P, eps);
        if (F <= 1e-6) continue;  // the muscle cannot pull here; nothing to invert
        const InverseResult inv = inverse_pressure(p, F, eps, kSupply_Pa);
        ASSERT_EQ(inv.status, InverseStatus::kOk) << "P=" << P << " eps=" << eps;
        EXPECT_NEAR(inv.pressure_Pa, P, 1e-9 * P) << "eps=" << eps;
        ++checked;
      }
    }
    EXPECT_GT(checked, 2000);
  }
}

// Forward of inverse: the force requested is the force the model makes at the returned pressure.
TEST(TendonSpring, ForwardOfInverseReturnsRequestedForce) {
  const TendonSpringParams p = dmsp40_nominal();
  for (double F = 1.0; F <= 2000.0; F += 7.0) {
    for (double eps = 0.0; eps <= 0.15; eps += 0.01) {
      const InverseResult inv = inverse_pressure(p, F, eps, kSupply_Pa);
      if (inv.status != InverseStatus::kOk) continue;
      EXPECT_NEAR(forward_force_N(p, inv.pressure_Pa, eps), F, 1e-7 * F);
    }
  }
}

// The wire's stretch makes the muscle contract further, so the force is below the rigid-wire one.
TEST(TendonSpring, WireStretchLowersForceBelowRigidWire) {
  TendonSpringParams elastic = dmsp40_nominal();
  TendonSpringParams rigid = elastic;
  rigid.k_N = 1e15;
  const double F_rigid = forward_force_N(rigid, 0.4e6, 0.1);
  const double F_elastic = forward_force_N(elastic, 0.4e6, 0.1);
  EXPECT_NEAR(F_rigid, 0.4e6 * gain_N_per_Pa(rigid, 0.1 + rigid.eps0), 1e-6);
  EXPECT_LT(F_elastic, F_rigid);
  EXPECT_GT(F_elastic, 0.8 * F_rigid);
}

TEST(TendonSpring, NonPhysicalRequestsGiveDocumentedFiniteResults) {
  const TendonSpringParams p = dmsp40_nominal();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(inverse_pressure(p, -50.0, 0.1, kSupply_Pa).status, InverseStatus::kNoForce);
  EXPECT_EQ(inverse_pressure(p, -50.0, 0.1, kSupply_Pa).pressure_Pa, 0.0);
  EXPECT_EQ(inverse_pressure(p, 0.0, 0.1, kSupply_Pa).pressure_Pa, 0.0);
  EXPECT_EQ(inverse_pressure(p, nan, 0.1, kSupply_Pa).status, InverseStatus::kNoForce);
  EXPECT_EQ(inverse_pressure(p, 100.0, nan, kSupply_Pa).status, InverseStatus::kInvalidInput);
  // A huge force saturates at the supply instead of asking for more.
  const InverseResult huge = inverse_pressure(p, 1e7, 0.1, kSupply_Pa);
  EXPECT_EQ(huge.pressure_Pa, kSupply_Pa);
  EXPECT_TRUE(huge.status == InverseStatus::kSaturated || huge.status == InverseStatus::kUnreachable);
  EXPECT_EQ(inverse_pressure(p, inf, 0.1, kSupply_Pa).status, InverseStatus::kNoForce);
  // g -> 0: a muscle whose gain vanishes at this contraction cannot pull; no division by ~0.
  TendonSpringParams flat = p;
  flat.a_N_per_Pa = 0.0;
  flat.b_N_per_Pa = -flat.c_N_per_Pa / 0.25;  // g(0.25) = 0
  EXPECT_EQ(inverse_pressure(flat, 10.0, 0.25 - flat.eps0, kSupply_Pa).status, InverseStatus::kUnreachable);
  EXPECT_EQ(forward_force_N(flat, 0.5e6, 0.3), 0.0);  // past g = 0: no pull
  EXPECT_EQ(forward_force_N(p, -1e5, 0.1), 0.0);
  EXPECT_EQ(forward_force_N(p, nan, 0.1), 0.0);
  EXPECT_EQ(forward_force_N(p, 0.3e6, inf), 0.0);
}

// Random inputs far outside the operating range never produce NaN or a pressure outside [0, max].
TEST(TendonSpring, NeverNaNUnderRandomInputs) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> P(-1e6, 3e6), eps(-1.0, 1.0), F(-5000.0, 1e5);
  for (const TendonSpringParams& p : {dmsp40_nominal(), dmsp10_nominal()}) {
    for (int i = 0; i < 100000; ++i) {
      const double f = forward_force_N(p, P(rng), eps(rng));
      ASSERT_TRUE(std::isfinite(f));
      ASSERT_GE(f, 0.0);
      const InverseResult inv = inverse_pressure(p, F(rng), eps(rng), kSupply_Pa);
      ASSERT_TRUE(std::isfinite(inv.pressure_Pa));
      ASSERT_GE(inv.pressure_Pa, 0.0);
      ASSERT_LE(inv.pressure_Pa, kSupply_Pa);
    }
  }
}

}  // namespace
}  // namespace peha::models
