#pragma once
/// \file
/// The one loop skeleton every experiment runs on (in-process or on the board, E1 to E6 and the
/// calibration recording): wait, read, step or hold, supervise, write.

#include "peha/io/backend.hpp"

#include <cstddef>
#include <cstdint>
#include <functional>

namespace peha::runtime {

/// What a loop does around each control cycle besides control. Both may be empty.
struct CycleHooks {
  /// Before reading the backend: e.g. sleep to the next absolute deadline.
  std::function<void()> wait;
  /// After the command was limited and before it is written. It may replace the command (a
  /// fault's safe command, a recovery ramp); returning false ends the run early. Called from the
  /// control loop: must not block or allocate.
  std::function<bool(const io::SensorState&, io::Command&, std::uint32_t limit_flags)> after;
};

/// The loop skeleton every experiment runner shares, for cycles k = 0..steps on `backend`: wait
/// (hooks.wait), read; on a new sample `step(k)` (control, limits, figures, log; returns the limit
/// flags), without one `hold(k)` and the last command goes out again (it also feeds a board's
/// watchdog); then hooks.after - which may end the run - and write, except after the last cycle.
/// Returns the last cycle run (< steps if a hook ended the run).
template <class Step, class Hold>
std::size_t run_cycles(io::Backend& backend, const CycleHooks& hooks, std::size_t steps, io::SensorState& state,
                       io::Command& command, Step&& step, Hold&& hold) {
  for (std::size_t k = 0; k <= steps; ++k) {
    if (hooks.wait) hooks.wait();
    std::uint32_t flags = 0;
    if (backend.read(state)) {
      flags = step(k);
    } else {
      hold(k);
    }
    if (hooks.after && !hooks.after(state, command, flags)) return k;
    if (k < steps) backend.write(command);
  }
  return steps;
}

}  // namespace peha::runtime
