#pragma once
/// \file
/// E1 on the multifunction board over UDP, in real time (docs/runtime.md): the same controller, limits
/// and analysis as the in-process run (`run_e1_on`), inside a RealtimeHarness (1 kHz absolute
/// deadlines, real-time thread, lifecycle with fault and recovery, writer-thread log with fault
/// dumps, telemetry, timing statistics).

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/common/board_run.hpp"
#include "peha/runtime/realtime_harness.hpp"

namespace peha::experiments {

struct E1RealtimeResult : BoardRunResult {
  E1Result e1;  ///< figures from the board's sensors (E1Result::from_truth is false)
};

/// Runs one E1 case on the board at `options.board`. Throws (set-up) if the scenario has no `mfb:`
/// section, the channel map is bad, or no board answers within the connect timeout.
E1RealtimeResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const runtime::RealtimeRunOptions& options);

}  // namespace peha::experiments
