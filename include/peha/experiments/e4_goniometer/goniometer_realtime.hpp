#pragma once
/// \file
/// An arm's E4 (goniometer) on the multifunction board over UDP, in real time: the same controller,
/// limits and analysis as in-process (`run_goniometer_on`), inside a RealtimeHarness.

#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/experiments/common/board_run.hpp"
#include "peha/runtime/realtime_harness.hpp"

namespace peha::experiments {

struct GoniometerRealtimeResult : BoardRunResult {
  GoniometerResult goniometer;  ///< the person's joints are the goniometers' readings; the exoskeleton's its encoders
};

/// E4 on the board: each driven joint's goniometer comes from its AD channel (the channel map's
/// `<joint>.goniometer`, e.g. R_EFE.goniometer), for as long as the scenario's movement `movement`
/// lasts. One session per call (the emulator resets its arm). Throws (set-up) without an `mfb:`
/// section, a driven joint's goniometer channel or a board.
GoniometerRealtimeResult run_goniometer_realtime(const ArmScenario& scenario, std::size_t movement, GoniometerVariant variant,
                                                 const HardwareRunOptions& options);

}  // namespace peha::experiments
