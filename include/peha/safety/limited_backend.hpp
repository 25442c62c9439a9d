#pragma once
/// \file
/// The limits stage at the backend boundary: an io::Backend that wraps another and limits every
/// command in write() (safety::apply_limits against the newest sample read through it) before it
/// passes it on. Experiments hold only this wrapper (runtime::run_cycles takes nothing else), so no
/// command reaches the outputs around the limits; what was sent is `sent()`, with its `flags()`.
/// Every sample read and every command written also passes the supervisor's plausibility stage
/// (safety::FaultMonitor): a latched fault replaces the command by its designed safe state (hold,
/// descend; vent deactivates the backend) in the same cycle, whatever the controller asks.
/// Lifecycle calls pass straight through. noexcept and allocation-free in the loop.

#include "peha/io/backend.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "peha/safety/limits.hpp"

#include <array>

namespace peha::safety {

class LimitedBackend final : public io::Backend {
 public:
  /// `limits` and `joints` (the joint set-ups the controller runs with) must outlive this.
  LimitedBackend(io::Backend& inner, const LimitsModel& limits, const JointModels& joints) noexcept
      : inner_(inner), limits_(limits), joints_(joints), monitor_(limits.monitor, limits.period_s, limits.test_overrides) {
    for (std::size_t j = 0; j < io::kMaxJoints; ++j) {
      min_angle_[j] = limits.joints[j].min_angle_rad;
      max_angle_[j] = limits.joints[j].max_angle_rad;
    }
  }

  const io::BackendInfo& info() const override { return inner_.info(); }
  void configure() override { inner_.configure(); }
  void activate() noexcept override { inner_.activate(); }
  void deactivate() noexcept override { inner_.deactivate(); }
  void estop() noexcept override { inner_.estop(); }
  io::BackendStatus status() const noexcept override { return inner_.status(); }
  bool read(io::SensorState& state) noexcept override {
    const bool fresh = inner_.read(state);
    if (fresh) {
      io::copy_used(last_state_, state);
      const io::BackendStatus status = inner_.status();
      monitor_.check_sample(state, joints_, min_angle_, max_angle_, status.active);
      if (status.estop) monitor_.estop_reported();
    }
    return fresh;
  }
  /// Checks `command`, replaces it by the safe state's while a fault is latched, limits it against
  /// the newest sample, then writes it.
  bool write(const io::Command& command) noexcept override {
    io::copy_used(sent_, command);
    monitor_.check_command(command, last_state_.time_s);
    const SafeAction before = vented_ ? SafeAction::kVent : SafeAction::kNone;
    monitor_.shape(sent_);
    if (monitor_.action() == SafeAction::kVent && before != SafeAction::kVent) {
      inner_.deactivate();  // outputs safe: motor off, valves (and the dump valve) vent slowly
      vented_ = true;
    }
    flags_ = apply_limits(limits_, joints_, data_, last_state_, sent_);
    monitor_.vent_escalated(sent_);  // below the pretension floor: a runaway's vented muscle
    monitor_.sent(sent_);
    return inner_.write(sent_);
  }

  const FaultMonitor& monitor() const noexcept { return monitor_; }
  /// The operator's recovery (runtime::run_cycles calls it when the supervisor recovers).
  void clear_faults() noexcept {
    monitor_.clear();
    vented_ = false;
  }

  /// What goes out is the controller's own command (FaultMonitor::controller_in_command).
  void controller_in_command(bool in_command) noexcept { monitor_.controller_in_command(in_command); }
  const io::Command& sent() const noexcept { return sent_; }  ///< the last command as limited and written
  std::uint32_t flags() const noexcept { return flags_; }     ///< its LimitFlag bits
  const LimitsData& data() const noexcept { return data_; }   ///< counts per flag, previous command

 private:
  io::Backend& inner_;
  const LimitsModel& limits_;
  JointModels joints_;
  LimitsData data_;
  io::SensorState last_state_{};
  io::Command sent_{};
  std::uint32_t flags_ = 0;
  FaultMonitor monitor_;
  std::array<double, io::kMaxJoints> min_angle_{}, max_angle_{};
  bool vented_ = false;
};

}  // namespace peha::safety
