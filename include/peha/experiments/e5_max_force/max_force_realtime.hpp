#pragma once
/// \file
/// E5 on the multifunction board over UDP, in real time (docs/runtime.md): the same ramp, limits and
/// analysis as the in-process run (`run_e5_on`), inside a RealtimeHarness, as E1's board run.

#include "peha/experiments/common/board_run.hpp"
#include "peha/experiments/e5_max_force/max_force.hpp"
#include "peha/runtime/realtime_harness.hpp"

namespace peha::experiments {

struct E5RealtimeResult : BoardRunResult {
  E5Result e5;  ///< figures from the board's sensors (E5Result::from_truth is false)
};

/// Runs one E5 case on the hardware `options.backend` (boards over UDP) in real time. Throws (set-up) if the scenario has no `mfb:`
/// section, the channel map is bad, or no board answers within the connect timeout.
E5RealtimeResult run_e5_realtime(const E5Scenario& scenario, const E5Case& c, const HardwareRunOptions& options);

}  // namespace peha::experiments
