#pragma once
/// \file
/// The run's lifecycle and fault path, the same for every backend (the in-process simulators and
/// the board over UDP): runtime::Lifecycle's named states driven through io::Backend's lifecycle
/// calls, fault detection from io::BackendStatus, the operator's recovery and the ramp back.
///
/// start(): configure (the board's session handshake) -> inactive -> activate -> active.
/// Each cycle, before the command goes to the limits stage, supervise():
/// - active: a fault when the backend is silent (no new sample for host_watchdog_s *and* for
///   kSilentCycles of the loop's own cycles in a row - a loop that was itself descheduled has not
///   heard a dead board, it has not listened), reports an e-stop, a restart of the board (its new
///   boot id: "board reboot"), or its watchdog tripped ->
///   fault: backend.deactivate() (outputs safe, valves vent slowly), on_fault(reason). A silent
///   backend is the exception: the host cannot see, but the board may still hear it (only its
///   state packets lost), so the outputs stay armed on the last command with the motor off (hold):
///   disarmed, the board vented a 5 kg payload onto its stop at 120-160 deg/s. Should the board go
///   safe on its own meanwhile (its watchdog, e-stop, a restart), the host disarms too.
/// - fault: recovery only on the operator's request (request_recovery(), or recover_after_s for
///   unattended runs) and only once the backend is alive, its e-stop released and it is ready to
///   arm: -> recovering (activate) -> inactive -> active once its outputs are armed again; not
///   armed within 0.5 s -> fault.
/// - after a recovery the command ramps from the pressures the muscles hold (motor off) to the
///   controller's over recovery_ramp_s - before the limits stage, so what is sent is what was
///   limited.
/// finish(): deactivate -> inactive -> finalized. noexcept and allocation-free in the loop.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/runtime/lifecycle.hpp"

#include <atomic>
#include <cstdint>
#include <functional>

namespace peha::runtime {

/// The lifecycle supervisor's parameters: the scenario's `lifecycle:` section (read_lifecycle), the
/// same in process and on the board; recover_after_s from the command line.
struct SupervisorParams {
  double host_watchdog_s = 0.02;  ///< no new sample this long (and kSilentCycles cycles) -> fault
  double recovery_ramp_s = 1.0;   ///< after a recovery, commands ramp from safe to the controller's
  double recover_after_s = -1.0;  ///< unattended operator: recover this long after a fault (< 0: only on request)
};

/// Reads the scenario's optional `lifecycle:` section (`host_watchdog_ms`, `recovery_ramp_s`; the
/// defaults above when absent) and finishes it.
SupervisorParams read_lifecycle(config::Map& root);

class Supervisor {
 public:
  static constexpr int kSilentCycles = 5;

  Supervisor(io::Backend& backend, const SupervisorParams& params) : backend_(backend), params_(params) {}

  /// Called (from the loop's thread) when a fault is raised, with its reason; may be empty.
  std::function<void(const char* reason)> on_fault;
  /// Called (from the loop's thread) when the operator's recovery re-arms the outputs: the command
  /// ramps from the measured pressures from this cycle on; the controller restarts from them too.
  std::function<void()> on_recover;

  /// configure + activate. Throws (set-up) if the backend cannot be configured.
  void start(double t_s);
  /// One cycle's supervision; `fresh`: this cycle read a new sample. May replace `command` (ramp).
  void supervise(double t_s, bool fresh, const io::SensorState& state, io::Command& command) noexcept;
  /// A fault the plausibility stage latched (safety::FaultMonitor): -> fault with `reason`; the
  /// outputs are already in their designed safe state (hold / descend / vent), so they are left as
  /// they are. Only while active.
  void raise(double t_s, const char* reason) noexcept;
  /// deactivate -> inactive -> finalized, with `reason`.
  void finish(double t_s, const char* reason) noexcept;
  /// The operator's recover command (any thread).
  void request_recovery() noexcept { recover_requested_ = true; }

  const Lifecycle& lifecycle() const noexcept { return lifecycle_; }
  /// Active and no recovery ramp: the controller's own command goes out (supervise leaves it as it is).
  bool controller_in_command() const noexcept { return lifecycle_.state() == LifecycleState::kActive && ramp_t_ < 0.0; }
  std::uint64_t faults() const noexcept { return faults_; }
  std::uint64_t recoveries() const noexcept { return recoveries_; }
  std::uint64_t cycles_without_sample() const noexcept { return missed_; }

 private:
  void fault(double t_s, const char* why) noexcept;
  /// fault() with the backend's part named (BackendStatus::part: "e-stop on board 'left'").
  void fault(double t_s, const char* why, const char* part) noexcept;
  /// A silent backend: -> fault, the outputs left armed on `command` with the motor off.
  void hold(double t_s, const io::Command& command, const char* part) noexcept;
  char reason_[160] = {};  ///< a fault reason with its part (the lifecycle copies it)

  io::Backend& backend_;
  SupervisorParams params_;
  Lifecycle lifecycle_;
  int silent_cycles_ = 0;
  std::uint64_t faults_ = 0, recoveries_ = 0, missed_ = 0;
  double fault_t_ = -1.0, ramp_t_ = -1.0;
  io::Command ramp_from_{};
  bool holding_ = false;  ///< faulted on a silent backend: held_ goes out, the outputs stay armed
  io::Command held_{};
  std::atomic<bool> recover_requested_{false};
};

}  // namespace peha::runtime
