#include "peha/runtime/supervisor.hpp"

#include "peha/io/udp_socket.hpp"

#include <algorithm>
#include <cstdio>

namespace peha::runtime {

SupervisorParams read_lifecycle(config::Map& root) {
  SupervisorParams p;
  if (!root.has("lifecycle")) return p;
  config::Map m = root.map("lifecycle");
  p.host_watchdog_s = m.number_or("host_watchdog_ms", p.host_watchdog_s * 1e3, {2.0, 250.0}) * 1e-3;
  // A recovery steps from the safe state to the controller's command: never in one cycle.
  p.recovery_ramp_s = m.number_or("recovery_ramp_s", p.recovery_ramp_s, {0.2, 10.0});
  m.finish();
  return p;
}

void Supervisor::start(double t_s) {
  // The handshake comes last in set-up, right before the enable edge: from a board's first answer
  // until an enabled command it holds its safe outputs and its plant vents; set-up in between would
  // start the run from a sagging arm, and more than the board's watchdog would trip it.
  backend_.configure();
  lifecycle_.apply(Transition::kConfigure, t_s, "configured: the backend answered");
  backend_.activate();
  lifecycle_.apply(Transition::kActivate, t_s, "outputs enabled");
}

void Supervisor::fault(double t_s, const char* why) noexcept {
  lifecycle_.apply(Transition::kFault, t_s, why);
  backend_.deactivate();
  ++faults_;
  fault_t_ = t_s;
  if (on_fault) on_fault(why);
}

void Supervisor::fault(double t_s, const char* why, const char* part) noexcept {
  if (!part) return fault(t_s, why);
  std::snprintf(reason_, sizeof reason_, "%s on %s", why, part);
  fault(t_s, reason_);
}

void Supervisor::hold(double t_s, const io::Command& command, const char* part) noexcept {
  const char* why = "backend silent for longer than host_watchdog_ms (holding the last command, motor off)";
  if (part) std::snprintf(reason_, sizeof reason_, "%s on %s", why, part);
  const char* reason = part ? reason_ : why;
  lifecycle_.apply(Transition::kFault, t_s, reason);
  ++faults_;
  fault_t_ = t_s;
  ramp_t_ = -1.0;
  holding_ = true;
  io::copy_used(held_, command);
  for (int j = 0; j < held_.joint_count; ++j) held_.joints[static_cast<std::size_t>(j)].motor_torque_Nm = 0.0;
  if (on_fault) on_fault(reason);
}

void Supervisor::raise(double t_s, const char* reason) noexcept {
  if (lifecycle_.state() != LifecycleState::kActive) return;
  lifecycle_.apply(Transition::kFault, t_s, reason);
  ++faults_;
  fault_t_ = t_s;
  ramp_t_ = -1.0;
  if (on_fault) on_fault(reason);
}

void Supervisor::supervise(double t_s, bool fresh, const io::SensorState& state, io::Command& cmd) noexcept {
  const io::BackendStatus status = backend_.status();
  if (!fresh) ++missed_;
  silent_cycles_ = fresh ? 0 : silent_cycles_ + 1;
  const double silent_for_s = status.last_sample_ns > 0 ? static_cast<double>(io::monotonic_ns() - status.last_sample_ns) * 1e-9
                                                        : silent_cycles_ * backend_.info().period_s;
  const bool silent = silent_cycles_ >= kSilentCycles && silent_for_s > params_.host_watchdog_s;
  switch (lifecycle_.state()) {
    case LifecycleState::kActive:
      if (silent) {
        hold(t_s, cmd, status.part);
      } else if (status.estop) {
        fault(t_s, "e-stop", status.part);
      } else if (status.rebooted) {
        fault(t_s, "board reboot", status.part);
      } else if (status.watchdog_tripped) {
        fault(t_s, "backend watchdog tripped", status.part);
      }
      break;
    case LifecycleState::kFault: {
      if (holding_ && (status.estop || status.rebooted || status.watchdog_tripped)) {
        holding_ = false;  // the board went safe on its own: nothing left to hold
        backend_.deactivate();
      }
      if (holding_) io::copy_used(cmd, held_);
      const bool asked = recover_requested_.exchange(false) || (params_.recover_after_s >= 0 && t_s - fault_t_ >= params_.recover_after_s);
      if (asked && !silent && !status.estop && status.ready_to_arm) {
        lifecycle_.apply(Transition::kRecover, t_s, "operator's command");
        holding_ = false;
        backend_.activate();  // the enable edge re-arms a board
        ramp_t_ = t_s;
        ramp_from_ = cmd;
        for (int j = 0; j < cmd.joint_count; ++j) {  // from what the muscles hold now, motor off
          const auto i = static_cast<std::size_t>(j);
          ramp_from_.joints[i].agonist_pressure_Pa = state.joints[i].agonist_pressure_Pa;
          ramp_from_.joints[i].antagonist_pressure_Pa = state.joints[i].antagonist_pressure_Pa;
          ramp_from_.joints[i].motor_torque_Nm = 0.0;
        }
        if (on_recover) on_recover();
      }
      break;
    }
    case LifecycleState::kRecovering:
      if (status.active) {
        lifecycle_.apply(Transition::kRecovered, t_s, "outputs re-armed");
        lifecycle_.apply(Transition::kActivate, t_s, "ramping back to the controller's command");
        ++recoveries_;
      } else if (t_s - ramp_t_ > 0.5) {
        lifecycle_.apply(Transition::kFault, t_s, "outputs did not re-arm within 0.5 s");
        backend_.deactivate();
        fault_t_ = t_s;
      }
      break;
    default:
      break;
  }
  // After a recovery: from what the muscles held to the controller's command, no jump.
  if (ramp_t_ >= 0.0 && lifecycle_.state() != LifecycleState::kFault) {
    const double s = params_.recovery_ramp_s > 0 ? std::clamp((t_s - ramp_t_) / params_.recovery_ramp_s, 0.0, 1.0) : 1.0;
    for (int j = 0; j < cmd.joint_count; ++j) {
      auto& o = cmd.joints[static_cast<std::size_t>(j)];
      const auto& f = ramp_from_.joints[static_cast<std::size_t>(j)];
      o.agonist_pressure_Pa = f.agonist_pressure_Pa + s * (o.agonist_pressure_Pa - f.agonist_pressure_Pa);
      o.antagonist_pressure_Pa = f.antagonist_pressure_Pa + s * (o.antagonist_pressure_Pa - f.antagonist_pressure_Pa);
      o.motor_torque_Nm = f.motor_torque_Nm + s * (o.motor_torque_Nm - f.motor_torque_Nm);
    }
    if (s >= 1.0) ramp_t_ = -1.0;
  }
}

void Supervisor::finish(double t_s, const char* reason) noexcept {
  backend_.deactivate();
  lifecycle_.apply(Transition::kDeactivate, t_s, reason);
  lifecycle_.apply(Transition::kShutdown, t_s, "run ended");
}

}  // namespace peha::runtime
