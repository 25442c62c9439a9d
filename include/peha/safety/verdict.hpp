#pragma once
/// \file
/// The one verdict type every experiment reports: a list of figures, each checked against its
/// threshold from the configuration, and the one definition of "within limits" (the safety
/// envelope) all experiments share.
///
/// The envelope, per actuated joint, over every observed cycle:
/// - each muscle's peak force <= its force ceiling (models::force_ceiling_N: the muscle's
///   configured max_force_N, never above the 2000 N wire limit);
/// - the lowest wire tension >= a fraction (VerdictThresholds::min_tension_fraction) of the joint's
///   configured pretension (a slack wire can jump off its pulley; a wire near 0 N is one bias away);
/// - the highest chamber pressure <= the joint's supply;
/// - the peak motor torque <= the motor's rating;
/// - the joint angle within the limits' range, give or take kRangeTolerance_rad (the limits layer
///   acts once a joint is past its range, so it may overshoot by a little before it stops).
/// Figures come from the simulator's truth in-process, from the sensors over hardware.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "peha/safety/limits.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace peha::safety {

/// The thresholds of the figures every experiment's verdict checks beyond the envelope, from the
/// scenario's optional `verdict:` section (docs/configuration.md); each key defaults to the value
/// here when absent. Angles in degrees, torque errors in percent of the plant's gravity torque.
struct VerdictThresholds {
  double max_drift_deg = 0.5;                ///< |angle drift| over the window after each release
  double stop_margin_deg = 2.0;              ///< after a release the joint stays this far from either end of its range
  double max_static_torque_error_pct = 5.0;  ///< |torque the friction holds at rest| / |gravity torque|
  double min_gravity_torque_Nm = 1.0;        ///< below this gravity torque a % error is not judged (e.g. arm hanging)
  double min_tension_fraction = 0.5;         ///< lowest wire tension >= this x the configured pretension
  /// Joints (bit i = joint i) whose pretension nothing controls, e.g. the right arm's wrist held at a
  /// constant pressure: no allocation keeps its wires at the pretension, so they are checked for
  /// slack (> 0 N) only. Set by the experiment from the controller's joint modes, not configurable.
  std::uint32_t slack_check_only_joints = 0;
  double max_tracking_rms_deg = 5.0;         ///< E4: RMS of exoskeleton - person elbow
  double max_tracking_error_deg = 15.0;      ///< E4: largest |exoskeleton - person elbow|
  /// E5 (the maximum-force ramp): the force holds at the limit while it stays within this band of
  /// where it stopped (the mean of the last second).
  double at_limit_band_N = 20.0;
  double max_force_overshoot_N = 0.0;        ///< E5: peak measured force - force ceiling
  double max_force_shortfall_N = 200.0;      ///< E5: force ceiling - held force (the model stops the force early)
  double max_settle_s = 1.0;                 ///< E5: from the limits' first cap to holding in the band
  double min_time_at_limit_s = 2.0;          ///< E5: time the measured force held at the limit
  double min_ceiling_share_pct = 95.0;       ///< E5: share of the held cycles the limits' force ceiling capped the ramp
  /// Start-up (vent, tare, refill; docs/safety.md "Start-up"): how far and how fast a joint may move
  /// while its muscles are vented on purpose and the limb rests on its support.
  double max_startup_excursion_deg = 2.0;
  double max_startup_speed_degps = 10.0;
};

/// Reads the optional `verdict:` section of a scenario root (defaults when absent or per key
/// absent); unknown keys and out-of-range values throw config::Error. Does not finish `root`.
VerdictThresholds read_verdict_thresholds(config::Map& root);

/// One figure checked against its threshold.
struct Check {
  enum class Rule { kAtMost, kAbove, kWithin, kAtLeast };
  std::string figure;  ///< e.g. "R_EFE agonist peak force"
  std::string unit;    ///< e.g. "N"
  double value = 0;
  double limit = 0;    ///< kAtMost: value <= limit; kAbove: value > limit; kAtLeast: value >= limit; kWithin: lower <= value <= limit
  double lower = 0;    ///< kWithin only
  Rule rule = Rule::kAtMost;
  bool passed() const noexcept;
  std::string describe() const;  ///< "R_EFE agonist peak force 2849 N > 630 N"
};

struct Verdict {
  std::vector<Check> checks;
  VerdictThresholds thresholds;  ///< what the experiment's figures were judged against (for reports)
  void at_most(std::string figure, std::string unit, double value, double limit);
  void above(std::string figure, std::string unit, double value, double limit);
  void at_least(std::string figure, std::string unit, double value, double limit);
  /// The check named `figure`, or nullptr.
  const Check* find(const std::string& figure) const noexcept;
  /// One line per check, "  ok   <describe>" / "  FAIL <describe>".
  std::string describe_all() const;
  void within(std::string figure, std::string unit, double value, double lower, double upper);
  /// Every check passed (and there is at least one).
  bool passed() const noexcept;
  /// The failed checks, one per line; empty when passed.
  std::string failures() const;
};

inline constexpr double kRangeTolerance_rad = 0.02;



/// One actuated joint at one cycle, as the envelope needs it.
struct JointSample {
  double muscle_force_N[2] = {0, 0};  ///< agonist, antagonist: muscle force (truth) or load cell
  double min_tension_N = 0;           ///< lowest along either wire (truth) or the lower load cell
  double pressure_Pa[2] = {0, 0};     ///< chamber (truth) or sensor
  double motor_torque_Nm = 0;         ///< delivered (truth) or commanded
  double angle_rad = 0;               ///< joint angle (truth) or encoder
};

/// Peaks and lows of the envelope's figures over a run, per joint. Allocation-free.
struct Envelope {
  struct Joint {
    double peak_muscle_force_N[2] = {0, 0};
    double min_tension_N = 1e300;
    double max_pressure_Pa = 0;
    double peak_motor_torque_Nm = 0;
    double min_angle_rad = 1e300, max_angle_rad = -1e300;
    std::uint64_t samples = 0;
  };
  std::array<Joint, io::kMaxJoints> joints{};
  void observe(std::size_t joint, const JointSample& s) noexcept;
  double peak_muscle_force_N() const noexcept;  ///< over all joints and muscles
  double min_tension_N() const noexcept;        ///< over all joints (+inf if nothing observed)
};

/// Adds the envelope's checks of joints 0..model.joint_count-1 (named `names`) to `verdict`, with
/// ceilings, supply, pretension and ratings from the joint set-ups, the range from the limits and the
/// tension floor min_tension_fraction x pretension from `thresholds`.
void add_envelope_checks(const LimitsModel& model, const JointModels& joints, const std::vector<std::string>& names,
                         const Envelope& envelope, const VerdictThresholds& thresholds, Verdict& verdict);

/// Speed over this window (not per sample): the encoders' counts make a per-sample difference noise.
inline constexpr double kStartupSpeedWindow_s = 0.01;

/// The start-up's figures of one joint: its largest |angle - angle at 0| and its largest speed over
/// kStartupSpeedWindow_s, from sample 0 to `end` (the end of vent, tare and refill), each judged
/// against the thresholds' max_startup_* (figures "<joint> start-up excursion", "... start-up speed").
void add_startup_checks(const std::string& joint, std::span<const double> angle_rad, double period_s, std::size_t end,
                        const VerdictThresholds& thresholds, Verdict& verdict);

/// The supervisor's figure every experiment reports: faults the plausibility stage latched over the
/// run, at most 0 (a faulted run never passes), the first fault's text in the figure's name.
void add_supervisor_check(const FaultMonitor& monitor, Verdict& v);

}  // namespace peha::safety
