#include "peha/control/motion_estimator.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace peha::control {
namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;

/// The state `x` predicted `tau_s` ahead on the constant-acceleration model.
MotionEstimate extrapolate(const MotionEstimate& x, double tau_s) noexcept {
  return {x.angle_rad + (x.rate_radps + 0.5 * x.acceleration_radps2 * tau_s) * tau_s, x.rate_radps + x.acceleration_radps2 * tau_s,
          x.acceleration_radps2};
}

void require_positive(const char* what, double v) {
  if (!(v > 0.0) || !std::isfinite(v)) throw std::invalid_argument(fmt::format("motion estimator: {} must be positive and finite, found {}", what, v));
}

}  // namespace

MotionEstimatorModel make_motion_estimator(double sample_rate_Hz, double noise_rad, double jerk_density_rad2ps5) {
  require_positive("sample_rate_Hz", sample_rate_Hz);
  require_positive("noise_rad", noise_rad);
  require_positive("jerk density (rad^2/s^5)", jerk_density_rad2ps5);
  const double T = 1.0 / sample_rate_Hz, q = jerk_density_rad2ps5, r = noise_rad * noise_rad;
  const Mat3 F = {{{1.0, T, 0.5 * T * T}, {0.0, 1.0, T}, {0.0, 0.0, 1.0}}};
  const double T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
  const Mat3 Q = {{{q * T5 / 20.0, q * T4 / 8.0, q * T3 / 6.0}, {q * T4 / 8.0, q * T3 / 3.0, q * T2 / 2.0}, {q * T3 / 6.0, q * T2 / 2.0, q * T}}};
  Mat3 P = Q;  // the posterior covariance; the Riccati recursion converges from any start
  MotionEstimatorModel m;
  m.sample_period_s = T;
  for (int it = 0; it < 100000; ++it) {
    Mat3 FP{}, Pp{};  // prior: F P F' + Q
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) FP[i][j] += F[i][k] * P[k][j];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        Pp[i][j] = Q[i][j];
        for (int k = 0; k < 3; ++k) Pp[i][j] += FP[i][k] * F[j][k];
      }
    const double s = Pp[0][0] + r;  // innovation variance (H = [1 0 0])
    std::array<double, 3> gain{Pp[0][0] / s, Pp[1][0] / s, Pp[2][0] / s};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) P[i][j] = Pp[i][j] - gain[i] * Pp[0][j];
    double change = 0.0;
    for (int i = 0; i < 3; ++i) change = std::max(change, std::abs(gain[i] - m.gain[i]) / std::max(std::abs(gain[i]), 1e-300));
    m.gain = gain;
    if (change < 1e-12) return m;
  }
  throw std::invalid_argument(fmt::format("motion estimator: the Kalman gains did not converge (rate {} Hz, noise {} rad, jerk density {})",
                                          sample_rate_Hz, noise_rad, jerk_density_rad2ps5));
}

void reset_motion_estimate(MotionEstimatorData& d, double angle_rad, double t_s) noexcept {
  d.posterior = d.previous = MotionEstimate{angle_rad, 0.0, 0.0};
  d.sample_time_s = d.previous_time_s = t_s;
  d.started = true;
}

void update_motion_estimate(const MotionEstimatorModel& m, MotionEstimatorData& d, double angle_rad, double t_s) noexcept {
  if (!d.started) {
    if (std::isfinite(angle_rad)) reset_motion_estimate(d, angle_rad, t_s);
    return;
  }
  // The prior at the sample's own time (a late or early sample predicts by its real interval).
  const MotionEstimate prior = extrapolate(d.posterior, t_s - d.sample_time_s);
  d.previous = d.posterior;
  d.previous_time_s = d.sample_time_s;
  d.sample_time_s = t_s;
  if (!std::isfinite(angle_rad)) {
    d.posterior = prior;
    return;
  }
  const double innovation = angle_rad - prior.angle_rad;
  d.posterior = {prior.angle_rad + m.gain[0] * innovation, prior.rate_radps + m.gain[1] * innovation,
                 prior.acceleration_radps2 + m.gain[2] * innovation};
}

MotionEstimate read_motion_estimate(const MotionEstimatorModel& m, const MotionEstimatorData& d, double t_s) noexcept {
  const MotionEstimate now = extrapolate(d.posterior, t_s - d.sample_time_s);
  const double w = std::clamp((t_s - d.sample_time_s) / m.sample_period_s, 0.0, 1.0);
  if (w >= 1.0) return now;
  const MotionEstimate before = extrapolate(d.previous, t_s - d.previous_time_s);
  return {before.angle_rad + w * (now.angle_rad - before.angle_rad), before.rate_radps + w * (now.rate_radps - before.rate_radps),
          before.acceleration_radps2 + w * (now.acceleration_radps2 - before.acceleration_radps2)};
}

}  // namespace peha::control
