#pragma once
/// \file
/// An arm scenario's E3 (postures) on the multifunction board over UDP, in real time: the same
/// controller, limits and analysis as in-process (`run_postures_on`), inside a RealtimeHarness.

#include "peha/experiments/common/board_run.hpp"
#include "peha/runtime/realtime_harness.hpp"
#include "peha/experiments/e3_postures/postures.hpp"

namespace peha::experiments {

struct PosturesRealtimeResult : BoardRunResult {
  PosturesResult postures;  ///< figures from the board's sensors (encoders, load cells)
};

/// Runs E3 on the hardware `options.backend` (boards over UDP) in real time; throws (set-up) without an `mfb:` section or a board.
PosturesRealtimeResult run_postures_realtime(const ArmScenario& scenario, const HardwareRunOptions& options);

}  // namespace peha::experiments
