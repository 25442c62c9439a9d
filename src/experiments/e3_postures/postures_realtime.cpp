#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

PosturesRealtimeResult run_postures_realtime(const ArmScenario& scenario, const runtime::RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  // One board or several (mfb: boards:), each io joint on its own board's link.
  const auto backend = mfb::make_boards_backend(*scenario.link, options.boards.empty() ? std::vector<io::UdpEndpoint>{options.board} : options.boards,
                                                scenario.period_s, arm_joint_names(scenario));
  std::string where;
  for (std::size_t b = 0; b < backend->board_count(); ++b) {
    const std::string& name = backend->board_name(b);
    where += fmt::format("{}{}udp://{}, session {:08x}", b ? "; " : "", name.empty() ? "" : "board '" + name + "' at ",
                         backend->board(b).board().to_string(), backend->board(b).session_id());
  }
  BoardRtts rtts(backend->board_count());
  backend->set_rtt_sink(&rtts);
  PosturesRealtimeResult res;
  {
    runtime::RealtimeHarness harness(*backend, supervisor_params(*scenario.link, options), options, scenario.period_s, postures_duration_s(scenario), "postures",
                            options.dir / "e3_postures.csv", arm_log_columns(scenario),
                            {fmt::format("case: E3 postures on the MFB at {}", where),
                             "plant_* and operator_torque columns are NaN: the host sees only the board's sensors"});
    const runtime::CycleHooks hooks = harness.start();
    res.postures = run_postures_on(scenario, *backend, nullptr, &harness.sink(), hooks);
    harness.finish(res);
    add_link_fault_check(res, res.postures.verdict);
    res.postures.within_limits = res.postures.verdict.passed();
    record_links(*backend, rtts, res);
  }
  return res;
}

}  // namespace peha::experiments
