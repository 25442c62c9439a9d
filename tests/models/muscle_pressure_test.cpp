// The muscle's pressure model as the control step uses it: muscle_pressure_pair (the pressure
// band's two ends in one residual pass) and muscle_pressure_interval (the allocation's anti-windup
// check without the residual when its bounds decide).
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/spgp.hpp"
#include "peha/models/joint.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

namespace peha::models {
namespace {

MuscleModel muscle_with_spgp_residual() {
  constexpr int kRows = 400;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> eps(0.0, 0.25), force(0.0, 1500.0);
  std::normal_distribution<double> noise(0.0, 1000.0);
  Eigen::MatrixXd X(kRows, 2);
  Eigen::VectorXd y(kRows);
  for (int n = 0; n < kRows; ++n) {
    X(n, 0) = eps(rng);
    X(n, 1) = force(rng);
    y[n] = 8e4 * std::sin(25.0 * X(n, 0)) + 3e4 * X(n, 1) / 1500.0 + noise(rng);
  }
  calibration::SpgpOptions options;
  options.num_pseudo = 20;
  options.max_iterations = 20;
  const auto spgp = std::make_shared<const calibration::Spgp>(calibration::Spgp::fit(X, y, options));
  MuscleModel m;
  m.pam = {-2e-4, 1e-4, 6e-4, 5e4, 0.01, 1e-6};
  m.residual = std::make_shared<const calibration::SpgpResidual>(spgp, calibration::Span{0.0, 0.25}, calibration::Span{0.0, 1500.0},
                                                                 calibration::Span{-0.1e6, 0.1e6});
  return m;
}

void expect_same(const InverseResult& a, const InverseResult& b) {
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.pressure_Pa, b.pressure_Pa);  // bit for bit
}

TEST(MusclePressure, PairEqualsTwoSingleEvaluationsAndTheIntervalHoldsThem) {
  const MuscleModel with = muscle_with_spgp_residual();
  MuscleModel without = with;
  without.residual = nullptr;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> eps(-0.1, 0.35), force(-100.0, 2500.0), supply(0.2e6, 0.8e6);
  for (int trial = 0; trial < 5000; ++trial) {
    const double e = eps(rng), fa = force(rng), fb = force(rng), s = supply(rng);
    for (const MuscleModel* m : {&with, static_cast<const MuscleModel*>(&without)}) {
      InverseResult pair[2];
      muscle_pressure_pair(*m, fa, fb, e, s, pair);
      expect_same(pair[0], muscle_pressure(*m, fa, e, s));
      expect_same(pair[1], muscle_pressure(*m, fb, e, s));
      const double p = muscle_pressure(*m, fa, e, s).pressure_Pa;
      const PressureInterval range = muscle_pressure_interval(*m, fa, e, s);
      EXPECT_LE(range.lo_Pa, p);
      EXPECT_GE(range.hi_Pa, p);
      if (m == &without) {
        EXPECT_EQ(range.lo_Pa, range.hi_Pa);
      }
    }
  }
  static_assert(noexcept(muscle_pressure_pair(with, 1.0, 2.0, 0.1, 1e5, nullptr)));
  static_assert(noexcept(muscle_pressure_interval(with, 1.0, 0.1, 1e5)));
}

}  // namespace
}  // namespace peha::models
