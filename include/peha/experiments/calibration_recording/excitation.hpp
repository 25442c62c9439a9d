#pragma once
/// \file
/// Calibration excitation (docs/calibration.md, paper Fig. 8): a triangle wave of pressure on one muscle while
/// the other holds a constant pressure (or moves in antiphase) and the joint moves; then, optionally,
/// operating-point segments: further triangles with their own pressure ranges that visit where the
/// controller works (e.g. the antagonist near its pretension at low pressure, the link held at
/// several angles). The load cell, the valve's pressure and the joint angle are logged at 250 Hz. It drives any `io::Backend` (the simulated rig by default,
/// the I/O board later) through the limits layer like every other command.

#include "peha/calibration/dataset.hpp"
#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/limits.hpp"

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace peha::experiments {

/// One operating-point segment: a triangle of the excited muscle's pressure with the partner in
/// antiphase (or constant), run after the main triangle.
struct ExcitationSegment {
  double min_pressure_Pa = 0.1e6;
  double max_pressure_Pa = 0.3e6;
  double period_s = 8.0;
  double duration_s = 16.0;
  double other_pressure_Pa = 0.1e6;         ///< partner while the excited muscle is at its top
  double other_pressure_at_min_Pa = 0.1e6;  ///< partner while the excited muscle is at its bottom
  /// The link clamped at this angle for the segment (a pin through the link on the rig), so the
  /// excited muscle's force sweeps a known contraction - E1's hold points whatever the plant's
  /// friction (`clamp_angle_deg`; NaN: free).
  double clamp_angle_rad = std::numeric_limits<double>::quiet_NaN();
};

/// The clamp the recording's clamped segments and the acceptance check use: a stiff, strong finger
/// at the link tip (50 kN/m at 0.4 m is 8 kNm/rad: a 20 Nm torque moves the link 0.14 deg).
inline constexpr double kClampStiffness_N_per_m = 50000.0;
inline constexpr double kClampDamping_Ns_per_m = 500.0;
inline constexpr double kClampMaxForce_N = 1000.0;

/// The excitation of one muscle.
struct ExcitationParams {
  double min_pressure_Pa = 0.05e6;    ///< bottom of the triangle
  double max_pressure_Pa = 0.45e6;    ///< top of the triangle
  double period_s = 12.0;             ///< one up-and-down
  double duration_s = 60.0;           ///< total
  double other_pressure_Pa = 0.25e6;  ///< the other muscle's pressure while the excited one is at its top
  /// The other muscle's pressure while the excited one is at its bottom; in between it moves in
  /// antiphase, so the link is driven through its range both ways despite the cable stiction.
  /// Equal to other_pressure_Pa: constant.
  double other_pressure_at_min_Pa = 0.25e6;
  double sample_rate_Hz = 250.0;      ///< logging rate (a divisor of the control rate)
  double payload_kg = 2.5;            ///< weight on the link while recording (simulated rig)
  /// Operating-point segments, run in order after the main triangle (`operating_points:`).
  std::vector<ExcitationSegment> segments;
  /// Load-cell tare before the excitation (`tare_s`, `vent_s`; tare_s 0 = none): both muscles
  /// commanded vented for vent_s + tare_s with the link clamped at 0 (the recording's clamp), the
  /// recorded muscle's load cell averaged over the last tare_s. That zero is subtracted from every
  /// recorded force and kept in the data (Dataset::loadcell_zero_N), so the calibration fits true
  /// force and a load-cell offset cannot enter the model.
  double tare_s = 0.0;
  double vent_s = 0.0;
  /// When the triangle starts: after the tare (0 without one).
  double excitation_start_s() const noexcept { return tare_s > 0.0 ? vent_s + tare_s : 0.0; }
  /// The tare, the main triangle and every segment.
  double total_duration_s() const noexcept;
};

/// The closed-loop check a calibration passes before it is used (`calibration.acceptance`): on the
/// rig, with the calibration on the paper's pure feed-forward (no force trim), the link is clamped
/// at each angle in turn for hold_s with each of the scenario's payloads;
/// over the last (hold_s - settle_s) of each hold, what the rig's sensors give is judged: the RMS
/// of (force request - load cell) per muscle and the lowest load-cell force.
struct CalibrationAcceptance {
  std::vector<double> angles_rad;        ///< hold angles, in order
  double hold_s = 3.0;                   ///< per angle
  double settle_s = 1.5;                 ///< the start of each hold (moving, settling) is not judged
  /// Per muscle, over every judged sample: RMS(force request - load cell) may reach the larger of
  /// max_force_tracking_rms_N and max_force_tracking_rms_fraction x RMS(force request). The floor
  /// judges a muscle near its pretension (the antagonist at 60 N), the fraction a loaded one (the
  /// agonist at 350-650 N), whose torque error E1 judges as a fraction of gravity.
  double max_force_tracking_rms_N = 25.0;
  double max_force_tracking_rms_fraction = 0.10;
  double min_tension_fraction = 0.5;     ///< lowest load-cell force >= this x the controller's pretension
};

/// Reads `calibration.acceptance` (angles in degrees) and finishes it.
CalibrationAcceptance read_calibration_acceptance(config::Map map);

/// Reads one muscle's `calibration.<muscle>` mapping (pressures in MPa) and finishes it.
ExcitationParams read_excitation(config::Map map);

/// Triangle wave value at time t after the excitation's start (excitation_start_s()): min at t = 0, max at period/2; after duration_s, the segment that
/// t falls in (each starting at its own minimum); after the last segment, its last value's wave.
double triangle_pressure_Pa(const ExcitationParams& e, double t_s) noexcept;
/// The other muscle's pressure at time t (antiphase between its two values).
double other_pressure_Pa(const ExcitationParams& e, double t_s) noexcept;

/// Runs the excitation of muscle `side` (+1 agonist, -1 antagonist) of joint 0 on `backend` and
/// returns the logged data (contraction from the controller's rigid-wire geometry, wire velocity
/// from a filtered encoder difference, forces less the tare's zero; no rows during the tare). `progress(fraction)` is called about once per second of data.
/// In real time on hardware `hooks` are the harness's (runtime::RealtimeHarness) and `log` its
/// per-cycle log (recording_log_columns()); in process both are empty.
calibration::Dataset record_excitation(io::Backend& backend, const models::JointModel& joint, int side,
                          const ExcitationParams& excitation, const safety::LimitsModel& limits,
                          const std::function<void(double)>& progress = {}, const runtime::CycleHooks& hooks = {},
                          runtime::RowSink* log = nullptr);

/// The per-cycle log of a recording on hardware: what the sensors gave and what was sent.
const std::vector<std::string>& recording_log_columns();

}  // namespace peha::experiments
