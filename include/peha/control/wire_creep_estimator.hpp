#pragma once
/// \file
/// Online tracking of wire creep and slack (docs/creep.md, issue 14 part 2).
///
/// Per muscle, the measured pressure P and tared load-cell force F, through the controller's own
/// Tendon-spring model inverted in contraction, give the contraction the muscle really has:
///
///     u_meas = g^-1(F / P_param),   P_param = P - residual(eps, F)   (the decreasing branch of g)
///
/// The model says u = eps_rigid(angle) + eps0 + F/k. Whatever the wire's length changed by since
/// the model was right, the muscle contracts that much further at the same angle, so one sample
/// measures the wire's length offset, m:
///
///     z = (u_meas - eps_rigid(angle) - eps0 - F/k) * L0
///
/// Samples are gated (pressure, force, joint speed, valve settled, load cell trusted), averaged
/// over blocks of `block_s`, and a scalar Kalman filter with a random-walk state tracks the offset.
/// The model's error depends on the operating point, so each (angle, force) bin learns its own
/// reference over `reference_s` of accepted blocks: the first one (after `reference_delay_s` of
/// taut wires) fixes the length at start-up, a later one is learned relative to the estimate then.
/// The estimate is the change since start-up, `length_change_m`, with its standard deviation. When
/// `correct` is set the allocation adds length_change_m / L0 to the contraction its pressure model
/// uses (AllocationData::contraction_offset).
///
/// Alerts (named, latched, advisory: they never stop a run): `creep_recalibrate` when
/// |length_change| - n_sigma * sigma > alert threshold; `wire_slack` when the load cell reads
/// below `slack_force_N` while the model, at the measured pressure, expects more than
/// `slack_model_force_N`, for `slack_s`.
///
/// Model/Data split: CreepEstimatorParams is constant, CreepEstimatorData the state;
/// `update_creep_estimator` is noexcept and allocation-free.

#include "peha/config/reader.hpp"
#include "peha/models/joint.hpp"
#include "peha/models/units.hpp"

#include <cmath>
#include <cstdint>

namespace peha::control {

struct CreepEstimatorParams {
  bool enabled = false;              ///< false: nothing is estimated, no correction, no alert
  bool correct = true;               ///< the estimate corrects the contraction of the pressure model
  /// Random-walk intensity of the wire's length change, m/sqrt(s): how fast the filter lets the
  /// estimate move (a creep of v m/s is followed with a lag of about v * sqrt(R * block_s) / q).
  double process_noise_m_per_sqrt_s = 2e-5;
  double block_s = 0.1;              ///< samples are averaged over blocks this long; one filter update per block, s
  /// Blocks count toward the reference only once the wires have been under tension this long: the
  /// start-up transient (muscles refilling, a trim converging) is not the state the model describes, s.
  double reference_delay_s = 10.0;
  /// Accepted block time that fixes an operating point's reference, s: the first point's fixes the
  /// length the estimate is relative to; a point met later learns its own (relative to the estimate then).
  double reference_s = 2.0;
  /// Width of the reference map's force bins, N (angle bins are 5 deg wide): the model's error
  /// depends on the operating point, so each (angle, force) bin keeps its own reference.
  double force_bin_N = 100.0;
  /// Relative uncertainty of the force model (g(u)), dimensionless: the systematic part of the
  /// measurement's uncertainty (it does not average out within a block).
  double model_force_fraction = 0.03;
  double loadcell_noise_N = 1.0;     ///< load-cell noise, N (1 sigma, per sample)
  double pressure_noise_Pa = 1000.0; ///< pressure-sensor noise, Pa (1 sigma, per sample)
  // Gating: a sample counts only where the inversion is well conditioned and the muscle static.
  double min_pressure_Pa = 0.05e6;   ///< below this (near the PAM's pressure threshold) no sample, Pa
  double min_force_N = 40.0;         ///< load-cell force below this: no sample, N
  double max_speed_radps = 0.02;     ///< |joint speed| above this: the muscle moves, no sample, rad/s
  /// |previous pressure command - measured pressure| above this: the valve has not settled, Pa.
  double settle_tolerance_Pa = 0.01e6;
  double max_correction_m = 0.010;   ///< bound of |length_change| the correction uses, m
  // Alerts.
  double alert_m = 0.001;            ///< creep_recalibrate when |length_change| - n_sigma sigma exceeds this, m
  double alert_sigmas = 2.0;         ///< n_sigma: the alert needs this much confidence
  /// The estimate's scale uncertainty (1 sigma, a fraction of |length_change|) added to the filter's
  /// sigma for the alert: the calibrated model's slope in contraction reads the creep 1.04-1.2x (the
  /// filter's own sigma does not know it; without it the antagonist's alert came 61-73 s early).
  double alert_scale_fraction = 0.1;
  double slack_force_N = 10.0;       ///< wire_slack: load cell below this, N ...
  double slack_model_force_N = 40.0; ///< ... while the model at the measured pressure expects more than this, N
  double slack_s = 0.2;              ///< ... for this long, s
  /// Where a learned residual is evaluated: false (default) at the rigid contraction, so the creep is
  /// read through the parametric model's slope and the measurement never depends on the estimate;
  /// true at the corrected one (rigid + estimate / L0), as the allocation uses it: the SPGP's own
  /// slope in the contraction then enters (docs/creep.md, "The measurement").
  bool residual_at_corrected_contraction = false;
  /// Multiplies every Kalman gain: 1 in every configuration (not a config key). Tests set 0 (an
  /// estimator that never moves) or -1 (the wrong sign) to prove the experiment's verdict fails.
  double gain_scale = 1.0;
};

/// Reads a `creep_estimator:` mapping (every key optional; units in the key names, lengths in mm,
/// pressures in MPa). Throws config::Error on an unknown key or a value out of range.
CreepEstimatorParams read_creep_estimator(config::Map map);

/// Alert bits (latched; CreepEstimatorData::alerts).
enum CreepAlert : std::uint32_t {
  kCreepRecalibrateAgonist = 1u << 0,
  kCreepRecalibrateAntagonist = 1u << 1,
  kWireSlackAgonist = 1u << 2,
  kWireSlackAntagonist = 1u << 3,
};
/// "creep_recalibrate agonist, wire_slack antagonist", ...; "" for none. Not for the loop (allocates).
const char* creep_alert_name(CreepAlert bit) noexcept;

/// What one step of the estimator sees (all from the hardware and the controller itself).
struct CreepEstimatorInput {
  double angle_rad = 0;
  double velocity_radps = 0;
  double loadcell_N[2] = {0, 0};            ///< tared (agonist, antagonist)
  double pressure_Pa[2] = {0, 0};           ///< measured (agonist, antagonist)
  double previous_pressure_cmd_Pa[2] = {0, 0};  ///< the controller's last pressure command
  bool loadcell_ok[2] = {true, true};       ///< the allocation's load-cell check
  bool tension_expected = true;             ///< false while the wires are slack on purpose (start-up tare)
  double time_s = 0;                        ///< the sample's time (for the alerts' time stamps), s
  double dt_s = 1e-3;                       ///< time since the previous step, s
};

/// One measurement of one muscle (computed every step; `valid` says whether it passed the gate).
struct CreepMeasurement {
  bool valid = false;
  double offset_m = 0;     ///< z: the wire's length offset this sample implies (absolute, not the change), m
  double variance_m2 = 0;  ///< its systematic variance (the model's uncertainty: it does not average out), m^2
  double noise_variance_m2 = 0;  ///< its sensor-noise variance per sample, m^2
};

/// Measures the length offset of muscle `m` (side +1 agonist, -1 antagonist): the model inverted
/// in contraction at the measured pressure and force (see the file comment). `valid` is false
/// where the inversion is undefined (no pressure, no force, g beyond its vertex, not finite).
/// The gate on speed and valve is not applied here.
/// A learned residual is evaluated at the rigid contraction plus `residual_offset_m` / L0.
CreepMeasurement measure_wire_offset(const models::MuscleModel& m, double pulley_radius_m, int side, double angle_rad,
                                     double pressure_Pa, double force_N, const CreepEstimatorParams& p,
                                     double residual_offset_m = 0.0) noexcept;

/// The reference map's grid: operating points binned by joint angle and load-cell force.
inline constexpr int kCreepAngleBins = 20;   ///< over [-50, 50) deg; outside: no sample
inline constexpr int kCreepForceBins = 10;   ///< of CreepEstimatorParams::force_bin_N each; the last takes the rest
inline constexpr int kCreepBins = kCreepAngleBins * kCreepForceBins;
inline constexpr double kCreepAngleBinLow_rad = models::deg_to_rad(-50.0);
inline constexpr double kCreepAngleBinWidth_rad = models::deg_to_rad(5.0);

/// The bin of an operating point (angle, force), or -1 outside the grid.
int creep_bin(double angle_rad, double force_N, double force_bin_N) noexcept;

/// One operating point's reference: the offset the model reads there when the wire had the length
/// the estimate is relative to (the model's error at that operating point, learned once).
struct CreepBin {
  double sum_m = 0;        ///< sum of block means while learning
  long blocks = 0;         ///< blocks learned so far
  double reference_m = 0;  ///< the learned reference, m
  bool learned = false;
};

struct CreepMuscleState {
  // Block accumulation.
  double block_time_s = 0;
  double block_sum_m = 0;
  double block_var_sum_m2 = 0;
  double block_noise_sum_m2 = 0;
  long block_samples = 0;
  int block_bin = -1;        ///< the operating point of the block's samples (-1: none yet)
  bool block_rejected = false;
  // Reference map: each operating point's offset at the wire length the estimate is relative to.
  CreepBin bins[kCreepBins];
  double reference_var_sum_m2 = 0;
  bool referenced = false;   ///< the first operating point learned: the estimate exists
  double reference_m = 0;    ///< the first operating point's reference (diagnostics), m
  // Filter: x = length change since the reference, m; variance m^2.
  double length_change_m = 0;
  double variance_m2 = 0;
  double last_offset_m = 0;  ///< the last block's mean offset, m (diagnostics)
  long updates = 0;          ///< filter updates
  double since_update_s = 0; ///< time since the last filter update, s
  bool gated = false;        ///< this step's sample was accepted
  double slack_time_s = 0;   ///< how long the slack condition has held, s
};

struct CreepEstimatorData {
  CreepMuscleState muscle[2];  ///< agonist, antagonist
  std::uint32_t alerts = 0;    ///< latched CreepAlert bits
  double alert_time_s[4] = {-1, -1, -1, -1};  ///< when each bit (in CreepAlert's order) latched, s; < 0: not yet
  double tension_time_s = 0;   ///< how long the wires have been under tension (tension_expected), s
};

/// One step. noexcept, allocation-free; non-finite inputs are gated out.
void update_creep_estimator(const models::JointModel& joint, const CreepEstimatorParams& p, CreepEstimatorData& d,
                            const CreepEstimatorInput& in) noexcept;

/// The length change muscle `i` (0 agonist, 1 antagonist) is corrected by, m: the estimate,
/// bounded by max_correction_m; 0 when disabled, not correcting or not yet referenced.
double creep_correction_m(const CreepEstimatorParams& p, const CreepEstimatorData& d, int i) noexcept;

/// The standard deviation of the estimate, m (0 before the reference).
inline double creep_sigma_m(const CreepEstimatorData& d, int i) noexcept {
  return d.muscle[i].referenced ? std::sqrt(d.muscle[i].variance_m2) : 0.0;
}

}  // namespace peha::control
