#pragma once
/// \file
/// The descend safe state's speed governor of one joint (docs/safety.md "descend"). The carrying
/// muscle - the one whose force, by the pressure model at the pressures held at the fault, is the
/// larger - gets a PI law on the joint's filtered speed toward descent_speed, tapering to a stop
/// stop_margin inside the range; its force becomes a pressure through the same pressure model the
/// limits use. The other muscle keeps the force it held (its wire stays taut); the motor damps.
/// safety::FaultMonitor runs it on every sample while its action is descend and shape() sends it.
/// noexcept and allocation-free.

#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"

#include <array>
#include <limits>

namespace peha::safety {

/// The governor's law, fixed for a run: safety::FaultMonitor builds it from MonitorParams' descent_*
/// keys (their defaults and the figures behind them are there).
struct DescendGovernorModel {
  double speed_radps = 0;            ///< the joint descends at this speed, never much faster
  double force_rate_N_per_s = 0;     ///< how fast the carrying force is bled while the joint does not descend
  double gain_N_per_radps = 0;       ///< force added per rad/s the joint descends too fast (proportional)
  double floor_fraction = 0;         ///< the bled force never below this x the force held at the fault
  double force_slew_N_per_s = 0;     ///< the carrying force rises at most this fast
  double damping_Nms_per_rad = 0;    ///< motor torque = -this x joint speed (within the rating)
  double stop_margin_rad = 0;        ///< the descent stops this far inside the range's end
  /// Moving up faster than this (beyond any wanted return into the range), the joint rises: kept
  /// (not bled) when an operator lifts it - the carrying force within balance_margin of its balance
  /// - since bled, the elbow's flexor fell to 1.0-2.5 N under an operator flexing it; bled and pushed
  /// back when the muscle itself lifts it. The descent speed; +inf only for the test that shows the
  /// old integral (CheckOverrides).
  double lift_speed_radps = 0;
  /// Rising with a carrying force above (1 + this) x the balance force (the force while the joint
  /// was last held or descending inside its range), the muscle lifts the joint, not an operator.
  double balance_margin = 0.1;
  /// Held still after an operator lifted it, the joint may be in the operator's hands: the force is
  /// bled at this fraction of force_rate until the joint descends on its own again (1: as any hold).
  /// Bled at the full rate, an arm an operator held up for a second fell when let go (the wrist
  /// whipped past the speed trip).
  double lifted_bleed_fraction = 1.0;
  /// Where a muscle's load cell is trusted (DescentSample::measured_N finite), its force is trimmed
  /// toward the commanded one at this rate (1/s; 0: the pressure model alone). The model errs most
  /// where the governor works (low pressure, long contraction): the arm's shoulder held 1 N at a
  /// pressure the model read as 268 N while an operator lifted it, then fell when let go.
  double trim_rate_per_s = 0;
  /// The commanded force the trim compares with the cell lags by this (the valves and the chamber),
  /// so that a catch's step does not wind the trim up before the muscle can follow.
  double trim_lag_s = 0.05;
  double period_s = 0;
};

/// One joint's governor: state from the fault on (started on its first sample), output per sample.
struct DescendGovernorData {
  bool started = false;
  int carrying = 0;             ///< 0 agonist (descends toward negative angles), 1 antagonist
  double force_N = 0;           ///< the bled (integral) part of the carrying force
  double command_N = 0;         ///< the carrying force commanded last (its rise is slew-limited)
  double floor_N = 0, ceiling_N = 0;
  double balance_N = 0;         ///< the carrying force while the joint was last held or descending inside its range (0: not yet)
  bool lifted = false;          ///< an operator lifted the joint and it has not descended on its own since
  double other_force_N = 0;     ///< the other muscle's force, held (>= the pretension)
  /// descent_runaway: the other muscle (the one pulling the joint down) is vented (FaultMonitor::vent_escalated).
  bool other_vented = false;
  std::array<double, 2> pressure_Pa{};  ///< the command (agonist, antagonist)
  double motor_Nm = 0;
  std::array<double, 2> lagged_N{};  ///< each muscle's commanded force lagged by trim_lag_s
  std::array<double, 2> trim_N{};    ///< added to each muscle's commanded force before the pressure model
};

/// What the governor reads of one sample.
struct DescentSample {
  double angle_rad = 0;
  double speed_radps = 0;  ///< the encoder's low-passed speed (the monitor's)
  double min_angle_rad = 0, max_angle_rad = 0;
  /// Each muscle's load cell less its declared zero, NaN where it is not trusted (the joint has a
  /// fault of its own: its cells may be what failed).
  std::array<double, 2> measured_N{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
};

/// One period of the governor: `held` is the joint's command before the fault (which muscle carries,
/// the forces it starts from); writes data.pressure_Pa and data.motor_Nm.
void govern_descent(const DescendGovernorModel& model, const models::JointModel& joint, const io::JointCommand& held,
                    const DescentSample& sample, DescendGovernorData& data) noexcept;

}  // namespace peha::safety
