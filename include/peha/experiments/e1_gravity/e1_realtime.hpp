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

/// Runs one E1 case on the hardware `options.backend` (a board) in real time. Throws (set-up) if the scenario has no `mfb:`
/// section, the channel map is bad, or no board answers within the connect timeout.
E1RealtimeResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const HardwareRunOptions& options);

/// The calibration recording of muscle `index` (0 agonist, 1 antagonist) on the hardware
/// `options.backend` (a board) in real time: the same excitation, limits and data as in process
/// (record_e1_muscle), through the lifecycle supervisor; each cycle logged to `cycles_log`
/// (recording_log_columns()). `verdict` holds the link faults: data recorded across one is not a
/// calibration's (the caller writes nothing then).
struct E1RecordingRealtimeResult : BoardRunResult {
  calibration::Dataset data;
  safety::Verdict verdict;
};
E1RecordingRealtimeResult record_e1_muscle_realtime(const E1Scenario& scenario, int index, const HardwareRunOptions& options,
                                                    const std::filesystem::path& cycles_log);

}  // namespace peha::experiments
