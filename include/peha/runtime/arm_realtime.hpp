#pragma once
/// \file
/// The right arm's E3 (postures) on the multifunction board over UDP, in real time: the same
/// controller, limits and analysis as in-process (`run_postures_on`), inside a RealtimeHarness.

#include "peha/runtime/e4_goniometer.hpp"
#include "peha/runtime/realtime_harness.hpp"
#include "peha/runtime/right_arm.hpp"

namespace peha::runtime {

struct PosturesRealtimeResult : RealtimeRunResult {
  PosturesResult postures;  ///< figures from the board's sensors (encoders, load cells)
};

/// The io joints of the right arm as the board's channel map names them (R_SFE, R_EFE, R_WFE).
const std::vector<std::string>& arm_joint_names(const ArmScenario& scenario);

/// Runs E3 on the board at `options.board`; throws (set-up) without an `mfb:` section or a board.
PosturesRealtimeResult run_postures_realtime(const ArmScenario& scenario, const RealtimeRunOptions& options);

struct GoniometerRealtimeResult : RealtimeRunResult {
  GoniometerResult goniometer;  ///< the person's elbow is the goniometer's reading; the exoskeleton's its encoder
};

/// E4 on the board: the goniometer comes from its AD channel (the channel map's R_EFE.goniometer),
/// for as long as the scenario's movement `movement` lasts. One session per call (the emulator
/// resets its arm). Throws (set-up) without an `mfb:` section, a goniometer channel or a board.
GoniometerRealtimeResult run_goniometer_realtime(const ArmScenario& scenario, std::size_t movement, GoniometerVariant variant,
                                                 const RealtimeRunOptions& options);

}  // namespace peha::runtime
