// The person's angle, rate and acceleration from a noisy 200 Hz goniometer (E4): the steady-state
// Kalman filter of a constant-acceleration model.
#include "peha/control/motion_estimator.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace peha::control {
namespace {

constexpr double kRate_Hz = 200.0, kControl_s = 0.001;
const double kNoise_rad = 0.2 * M_PI / 180.0;  // E4's goniometer

// A constant acceleration is the model's own motion: once converged, the estimate is the parabola
// itself, at the samples and between them (no lag, unlike a low-pass).
TEST(MotionEstimator, FollowsAConstantAccelerationWithoutLag) {
  const MotionEstimatorModel m = make_motion_estimator(kRate_Hz, kNoise_rad, 25.0);
  MotionEstimatorData d;
  const double a = 3.0;  // rad/s^2
  auto angle = [&](double t) { return 0.5 + 0.2 * t + 0.5 * a * t * t; };
  for (int k = 0; k <= 600; ++k) update_motion_estimate(m, d, angle(k / kRate_Hz), k / kRate_Hz);
  for (const double t : {3.0, 3.001, 3.0025, 3.0049}) {
    const MotionEstimate e = read_motion_estimate(m, d, t);
    EXPECT_NEAR(e.angle_rad, angle(t), 1e-9) << t;
    EXPECT_NEAR(e.rate_radps, 0.2 + a * t, 1e-7) << t;
    EXPECT_NEAR(e.acceleration_radps2, a, 1e-5) << t;
  }
}

/// RMS of the acceleration estimate of a still person seen through E4's goniometer noise, read at the
/// control rate over 20 s after 2 s of convergence.
double still_acceleration_noise_radps2(double jerk_density) {
  const MotionEstimatorModel m = make_motion_estimator(kRate_Hz, kNoise_rad, jerk_density);
  MotionEstimatorData d;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, kNoise_rad);
  double sum = 0.0;
  int n = 0;
  for (int k = 0; k < 22000; ++k) {
    const double t = k * kControl_s;
    if (k % 5 == 0) update_motion_estimate(m, d, 1.0 + noise(rng), t);
    if (t < 2.0) continue;
    const double acc = read_motion_estimate(m, d, t).acceleration_radps2;
    sum += acc * acc;
    ++n;
  }
  return std::sqrt(sum / n);
}

// The second difference of 0.2 deg noise at 200 Hz is sqrt(6) x 0.0035 rad x 200^2 = 340 rad/s^2 RMS
// (46 Nm on the 0.135 kg m^2 forearm and hand); the estimator at E4's jerk density (25 rad^2/s^5)
// keeps about 1 % of it, and a lower density less (the price is lag).
TEST(MotionEstimator, AccelerationIsQuietAndTheJerkDensityTradesNoise) {
  const double shipped = still_acceleration_noise_radps2(25.0);
  EXPECT_LT(shipped, 5.0);
  EXPECT_GT(shipped, 0.1);
  EXPECT_LT(still_acceleration_noise_radps2(1.0), 0.5 * shipped);
  EXPECT_GT(still_acceleration_noise_radps2(1000.0), 2.0 * shipped);
}

// Between samples the estimate blends from the previous posterior's extrapolation to the new one's
// over one sample period: it does not step when a sample arrives.
TEST(MotionEstimator, DoesNotStepWhenASampleArrives) {
  const MotionEstimatorModel m = make_motion_estimator(kRate_Hz, kNoise_rad, 25.0);
  MotionEstimatorData d;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, kNoise_rad);
  double largest_step = 0.0, largest_innovation_step = 0.0;
  MotionEstimate last{};
  for (int k = 0; k < 5000; ++k) {
    const double t = k * kControl_s;
    if (k % 5 == 0) {
      const MotionEstimate before = read_motion_estimate(m, d, t);
      update_motion_estimate(m, d, 1.0 + noise(rng), t);
      if (k > 1000) largest_innovation_step = std::max(largest_innovation_step, std::abs(d.posterior.acceleration_radps2 - before.acceleration_radps2));
    }
    const MotionEstimate e = read_motion_estimate(m, d, t);
    if (k > 1000) largest_step = std::max(largest_step, std::abs(e.acceleration_radps2 - last.acceleration_radps2));
    last = e;
  }
  // Each correction spread over five control cycles: at most ~1/5 of a posterior's jump per cycle.
  EXPECT_LT(largest_step, 0.3 * largest_innovation_step);
  EXPECT_GT(largest_innovation_step, 0.0);
}

TEST(MotionEstimator, SkipsANonFiniteSampleAndRefusesBadParameters) {
  const MotionEstimatorModel m = make_motion_estimator(kRate_Hz, kNoise_rad, 25.0);
  MotionEstimatorData d;
  update_motion_estimate(m, d, 1.0, 0.0);
  update_motion_estimate(m, d, std::numeric_limits<double>::quiet_NaN(), 0.005);
  EXPECT_NEAR(read_motion_estimate(m, d, 0.005).angle_rad, 1.0, 1e-12);
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_THROW(make_motion_estimator(bad, kNoise_rad, 25.0), std::invalid_argument);
    EXPECT_THROW(make_motion_estimator(kRate_Hz, bad, 25.0), std::invalid_argument);
    EXPECT_THROW(make_motion_estimator(kRate_Hz, kNoise_rad, bad), std::invalid_argument);
  }
}

TEST(MotionEstimator, UpdatesAndReadsWithoutAllocating) {
  const MotionEstimatorModel m = make_motion_estimator(kRate_Hz, kNoise_rad, 25.0);
  MotionEstimatorData d;
  double sink = 0.0;
  const std::size_t allocations = testing::allocations_during([&] {
    for (int k = 0; k < 1000; ++k) {
      if (k % 5 == 0) update_motion_estimate(m, d, 0.001 * k, k * kControl_s);
      sink += read_motion_estimate(m, d, k * kControl_s).acceleration_radps2;
    }
  });
  EXPECT_EQ(allocations, 0u);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
}  // namespace peha::control
