#pragma once
/// \file
/// The one loop every experiment runs on (E1, E3, E4, E6 and the calibration recording; in-process
/// or on the board): wait, read, step or hold, supervise, limit and write, observe.
///
/// The loop only ever writes through safety::LimitedBackend, so every command passes the limits
/// stage at the backend boundary, and through a runtime::Supervisor, so every run has the same
/// lifecycle and fault path. The supervisor's recovery ramp shapes the command *before* the limits:
/// what is sent is what was limited.

#include "peha/io/backend.hpp"
#include "peha/runtime/interrupt.hpp"
#include "peha/runtime/supervisor.hpp"
#include "peha/safety/limited_backend.hpp"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace peha::runtime {

/// What a loop does around each control cycle besides control. All may be empty.
struct CycleHooks {
  /// Before reading the backend: e.g. sleep to the next absolute deadline.
  std::function<void()> wait;
  /// The run's supervisor (a real-time harness's). Null: run_cycles starts its own with `lifecycle`
  /// on the backend and finishes it after the last cycle (in-process runs).
  Supervisor* supervisor = nullptr;
  /// The parameters of the supervisor run_cycles starts itself (the scenario's `lifecycle:`).
  SupervisorParams lifecycle;
  /// After the write, with the command as sent: timing, telemetry, progress. Returning false ends
  /// the run. Called from the control loop: must not block or allocate.
  std::function<bool(const io::SensorState&, const io::Command& sent)> after;
  /// Once, right after the last cycle, on the loop's thread, before the experiment works on its
  /// results: what the loop alone did ends here (a real-time harness's thread counters).
  std::function<void()> done;
  /// Once, after the last cycle and before an own supervisor finishes, with the run's supervisor:
  /// its lifecycle's transitions (faults, recoveries) for the experiment's result.
  std::function<void(const Supervisor&)> finished;
  /// Each time the supervisor starts the operator's recovery (Supervisor::on_recover, after any it
  /// has): the controller's commands did not go out since the fault; it restarts from what is measured.
  std::function<void()> recovered;
};

/// `hooks` with the scenario's `lifecycle` for the supervisor run_cycles starts itself in process
/// (a harness's own supervisor, configured from the same section, is left as it is).
inline CycleHooks with_lifecycle(CycleHooks hooks, const SupervisorParams& lifecycle) {
  hooks.lifecycle = lifecycle;
  return hooks;
}

/// `hooks` whose recovery first restarts the controller from what is measured now (`resume`: an
/// allocation's trims wound up while its commands did not go out, e.g. ArmController::resume), then
/// runs the hooks' own. Every loop whose controller integrates takes its hooks through this.
inline CycleHooks resuming(CycleHooks hooks, std::function<void()> resume) {
  hooks.recovered = [resume = std::move(resume), outer = std::move(hooks.recovered)] {
    resume();
    if (outer) outer();
  };
  return hooks;
}

/// `hooks` that copy the run's lifecycle transitions into `history` when the run finishes (oldest
/// first), then run the hooks' own `finished`.
inline CycleHooks recording_lifecycle(CycleHooks hooks, std::vector<LifecycleEvent>& history) {
  hooks.finished = [&history, outer = std::move(hooks.finished)](const Supervisor& supervisor) {
    history = history_of(supervisor.lifecycle());
    if (outer) outer(supervisor);
  };
  return hooks;
}

/// Runs cycles k = 0..steps on `backend`: wait, read; with a new sample `step(k)` computes
/// `command`, without one `hold(k)` and the previous command goes out again (it also feeds a board's
/// watchdog); the supervisor supervises (it may fault the run or ramp the command); the command is
/// limited and written; with a new sample `observe(k, sent, limit_flags)` records figures and log
/// rows (a simulator's `sampled_truth()` is the truth of that sample); then hooks.after. Returns
/// the last cycle run (< steps if a hook ended the run).
template <class Step, class Hold, class Observe>
std::size_t run_cycles(safety::LimitedBackend& backend, const CycleHooks& hooks, std::size_t steps, io::SensorState& state,
                       io::Command& command, Step&& step, Hold&& hold, Observe&& observe) {
  const double period_s = backend.info().period_s;
  std::optional<Supervisor> own;
  if (!hooks.supervisor) {
    own.emplace(backend, hooks.lifecycle);
    own->start(0.0);
  }
  Supervisor& supervisor = hooks.supervisor ? *hooks.supervisor : *own;
  const std::function<void()> outer_recover = supervisor.on_recover;
  if (hooks.recovered) {
    supervisor.on_recover = [&outer_recover, &hooks] {
      if (outer_recover) outer_recover();
      hooks.recovered();
    };
  }
  std::size_t k = 0;
  for (; k <= steps; ++k) {
    if (hooks.wait) hooks.wait();
    const bool fresh = backend.read(state);
    if (fresh) {
      step(k);
    } else {
      hold(k);
    }
    const double t_s = static_cast<double>(k) * period_s;
    supervisor.supervise(t_s, fresh, state, command);
    // The plausibility stage's faults (in LimitedBackend: the outputs already safe) fault the run;
    // the operator's recovery clears its latch.
    if (backend.monitor().flags() != 0) supervisor.raise(t_s, backend.monitor().reason());
    if (supervisor.lifecycle().state() == LifecycleState::kRecovering && backend.monitor().flags() != 0) backend.clear_faults();
    backend.controller_in_command(supervisor.controller_in_command());
    backend.write(command);
    if (fresh) observe(k, backend.sent(), backend.flags());
    if (hooks.after && !hooks.after(state, backend.sent())) break;
    if (interrupt_requested()) break;  // Ctrl-C: the run ends here and winds down as at its end
  }
  if (hooks.done) hooks.done();
  if (hooks.finished) hooks.finished(supervisor);
  supervisor.on_recover = outer_recover;
  const std::size_t last = std::min(k, steps);
  if (own) own->finish(static_cast<double>(last) * period_s, "experiment finished");
  return last;
}

}  // namespace peha::runtime
