#include "peha/sim/output_gate.hpp"

#include <algorithm>

namespace peha::sim {

void OutputGate::go_safe() noexcept {
  if (active_) {
    vent_from_ = applied_;
    safe_for_s_ = 0.0;
  }
  active_ = false;
}

void OutputGate::activate() noexcept {
  if (!estop_ && off_periods_ <= 0) active_ = true;
}

void OutputGate::deactivate() noexcept {
  go_safe();
  estop_ = false;
  rebooted_ = false;
}

// Both are called before this period's apply(), which counts one down: + 1, so that exactly
// duration_s / period_s samples are missed.
void OutputGate::lose_samples(double duration_s) noexcept { lost_periods_ = std::max(lost_periods_, std::lround(duration_s / period_s_) + 1); }

void OutputGate::reboot(double duration_s) noexcept {
  go_safe();
  off_periods_ = std::max(off_periods_, std::lround(duration_s / period_s_) + 1);
}

void OutputGate::estop() noexcept {
  go_safe();
  estop_ = true;
}

io::BackendStatus OutputGate::status() const noexcept {
  io::BackendStatus s;
  s.active = active_;
  s.estop = estop_;
  s.ready_to_arm = !estop_ && off_periods_ <= 0;
  s.rebooted = rebooted_;
  return s;
}

const io::Command& OutputGate::apply(const io::Command& wanted) noexcept {
  if (lost_periods_ > 0) --lost_periods_;
  if (off_periods_ > 0 && --off_periods_ == 0) rebooted_ = true;  // booted again: disarmed, says so
  if (active_) {
    applied_ = wanted;
    return applied_;
  }
  safe_for_s_ += period_s_;
  const double left = std::clamp(1.0 - safe_for_s_ / vent_s_, 0.0, 1.0);
  applied_.joint_count = wanted.joint_count;
  for (int j = 0; j < wanted.joint_count; ++j) {
    const auto i = static_cast<std::size_t>(j);
    applied_.joints[i].agonist_pressure_Pa = left * vent_from_.joints[i].agonist_pressure_Pa;
    applied_.joints[i].antagonist_pressure_Pa = left * vent_from_.joints[i].antagonist_pressure_Pa;
    applied_.joints[i].motor_torque_Nm = 0.0;
  }
  return applied_;
}

}  // namespace peha::sim
