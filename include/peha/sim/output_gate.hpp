#pragma once
/// \file
/// The simulated hardware's lifecycle (io::Backend's activate/deactivate/estop/status) for the
/// in-process plants: whether the actuators follow the commands, and what they get when not - the
/// same safe state a board holds: motor torque 0, every valve's pressure command ramped linearly
/// from where it was to 0 over `vent_s` (a controlled vent, not a drop: a sudden vent lets the arm
/// fall). noexcept and allocation-free after construction.

#include "peha/io/backend.hpp"

#include <cmath>

namespace peha::sim {

/// How long the simulated hardware takes to vent its valves in the safe state, s (a board's default).
inline constexpr double kSafeVent_s = 2.0;

class OutputGate {
 public:
  /// `period_s`: one write() per period; `vent_s`: how long the safe state takes to vent (> 0).
  OutputGate(double period_s, double vent_s) noexcept : period_s_(period_s), vent_s_(vent_s > 0 ? vent_s : period_s) {}

  /// Outputs follow the commands; refused (stays safe) while an e-stop is latched.
  void activate() noexcept;
  /// Safe outputs; also releases a latched e-stop (the next activate() re-arms).
  void deactivate() noexcept;
  /// Safe outputs now, latched until deactivate().
  void estop() noexcept;
  io::BackendStatus status() const noexcept;

  /// The board's state packets are lost for `duration_s` from now: samples() is false meanwhile;
  /// the outputs go on following the commands (the board still hears the host).
  void lose_samples(double duration_s) noexcept;
  /// The board is off for `duration_s` from now: safe outputs, no samples, not ready to arm; then
  /// it is back, disarmed, reporting its restart (status().rebooted) until deactivate().
  void reboot(double duration_s) noexcept;
  /// A sample reaches the host this period (no state loss, the board on).
  bool samples() const noexcept { return lost_periods_ <= 0 && off_periods_ <= 0; }

  /// The command the actuators get this period: `wanted` while active, else the safe command.
  const io::Command& apply(const io::Command& wanted) noexcept;

 private:
  void go_safe() noexcept;

  double period_s_, vent_s_;
  bool active_ = false, estop_ = false, rebooted_ = false;
  long lost_periods_ = 0;   ///< state packets lost this many periods longer
  long off_periods_ = 0;    ///< the board off this many periods longer
  io::Command applied_{};   ///< what the actuators got last period
  io::Command vent_from_{}; ///< the command when the outputs went safe
  double safe_for_s_ = 0;   ///< time in the safe state
};

}  // namespace peha::sim
