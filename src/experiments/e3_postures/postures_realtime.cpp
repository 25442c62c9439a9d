#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

PosturesRealtimeResult run_postures_realtime(const ArmScenario& scenario, const runtime::RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const auto backend = mfb::make_board_backend(*scenario.link, options.board, scenario.period_s, arm_joint_names(scenario));
  PosturesRealtimeResult res;
  {
    runtime::RealtimeHarness harness(*backend, supervisor_params(*scenario.link, options), options, scenario.period_s, postures_duration_s(scenario), "postures",
                            options.dir / "e3_postures.csv", arm_log_columns(scenario),
                            {fmt::format("case: E3 postures on the MFB at udp://{}, session {:08x}", options.board.to_string(),
                                         backend->session_id()),
                             "plant_* and operator_torque columns are NaN: the host sees only the board's sensors"});
    const runtime::CycleHooks hooks = harness.start();
    res.postures = run_postures_on(scenario, *backend, nullptr, &harness.sink(), hooks);
    harness.finish(res);
    add_link_fault_check(res, res.postures.verdict);
    res.postures.within_limits = res.postures.verdict.passed();
    res.link = backend->stats();
  }
  return res;
}

}  // namespace peha::experiments
