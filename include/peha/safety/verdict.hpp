#pragma once
/// \file
/// The one verdict type every experiment reports: a list of figures, each checked against its
/// threshold from the configuration, and the one definition of "within limits" (the safety
/// envelope) all experiments share.
///
/// The envelope, per actuated joint, over every observed cycle:
/// - each muscle's peak force <= its force ceiling (models::force_ceiling_N: the muscle's
///   configured max_force_N, never above the 2000 N wire limit);
/// - the lowest wire tension > 0 N (a slack wire can jump off its pulley);
/// - the highest chamber pressure <= the joint's supply;
/// - the peak motor torque <= the motor's rating;
/// - the joint angle within the limits' range, give or take kRangeTolerance_rad (the limits layer
///   acts once a joint is past its range, so it may overshoot by a little before it stops).
/// Figures come from the simulator's truth in-process, from the sensors over hardware.

#include "peha/io/backend.hpp"
#include "peha/safety/limits.hpp"

#include <array>
#include <string>
#include <vector>

namespace peha::safety {

/// One figure checked against its threshold.
struct Check {
  enum class Rule { kAtMost, kAbove, kWithin };
  std::string figure;  ///< e.g. "R_EFE agonist peak force"
  std::string unit;    ///< e.g. "N"
  double value = 0;
  double limit = 0;    ///< kAtMost: value <= limit; kAbove: value > limit; kWithin: lo <= value <= limit
  double lower = 0;    ///< kWithin only
  Rule rule = Rule::kAtMost;
  bool passed() const noexcept;
  std::string describe() const;  ///< "R_EFE agonist peak force 2849 N > 630 N"
};

struct Verdict {
  std::vector<Check> checks;
  void at_most(std::string figure, std::string unit, double value, double limit);
  void above(std::string figure, std::string unit, double value, double limit);
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
/// ceilings, supply and ratings from the joint set-ups and the range from the limits.
void add_envelope_checks(const LimitsModel& model, const JointModels& joints, const std::vector<std::string>& names,
                         const Envelope& envelope, Verdict& verdict);

}  // namespace peha::safety
