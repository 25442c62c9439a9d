#pragma once
/// \file
/// A person's joint angle, rate and acceleration from a noisy angle sensor sampled slower than the
/// control loop (E4: a 200 Hz goniometer read by a 1 kHz loop; docs/right-arm.md, E4).
///
/// The steady-state Kalman filter of a constant-acceleration model driven by white jerk (an
/// alpha-beta-gamma filter): state x = (angle, rate, acceleration), prediction over one sample period
/// T by F = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]], process noise of the jerk's spectral density q
/// (rad^2/s^5) through Q = q [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]],
/// measurement noise R = sigma^2. Its acceleration is far quieter than a low-pass's second difference
/// for the same lag of the angle; q trades the acceleration's noise for its lag.
///
/// Between samples the estimate is read at any instant: the new posterior's extrapolation blended in
/// linearly over one sample period from the previous posterior's (each correction spread over T
/// instead of a step every T: no staircase at the sample rate).
///
/// Model/Data: `MotionEstimatorModel` is made once (`make_motion_estimator` throws
/// std::invalid_argument on bad parameters); `MotionEstimatorData` holds the state;
/// `update_motion_estimate` and `read_motion_estimate` are noexcept and allocation-free.

#include <array>

namespace peha::control {

/// Angle, rate and acceleration of one joint.
struct MotionEstimate {
  double angle_rad = 0.0;
  double rate_radps = 0.0;
  double acceleration_radps2 = 0.0;
};

/// The estimator's constants: the sample period and the steady-state Kalman gains.
struct MotionEstimatorModel {
  double sample_period_s = 0.005;
  std::array<double, 3> gain{};  ///< steady-state gains of angle (1), rate (1/s), acceleration (1/s^2)
};

/// The steady-state gains for a sensor sampled at `sample_rate_Hz` with noise `noise_rad` (standard
/// deviation, quantisation included) and a person whose jerk has spectral density
/// `jerk_density_rad2ps5` (rad^2/s^5): the Riccati recursion iterated to convergence. Throws
/// std::invalid_argument on a non-positive or non-finite parameter.
MotionEstimatorModel make_motion_estimator(double sample_rate_Hz, double noise_rad, double jerk_density_rad2ps5);

/// The estimator's state.
struct MotionEstimatorData {
  MotionEstimate posterior;      ///< after the latest sample
  MotionEstimate previous;       ///< after the sample before it
  double sample_time_s = 0.0;    ///< when the latest sample came
  double previous_time_s = 0.0;  ///< when the one before came
  bool started = false;
};

/// Starts at rest at `angle_rad` at time `t_s` (rate and acceleration 0).
void reset_motion_estimate(MotionEstimatorData& d, double angle_rad, double t_s) noexcept;
/// Feeds the sample `angle_rad` taken at `t_s` (the first one starts the estimator at rest there).
/// A non-finite sample is skipped (the prediction carries on).
void update_motion_estimate(const MotionEstimatorModel& m, MotionEstimatorData& d, double angle_rad, double t_s) noexcept;
/// The estimate at `t_s` (at or after the latest sample): the new posterior's extrapolation blended in
/// over one sample period from the previous one's.
MotionEstimate read_motion_estimate(const MotionEstimatorModel& m, const MotionEstimatorData& d, double t_s) noexcept;

}  // namespace peha::control
