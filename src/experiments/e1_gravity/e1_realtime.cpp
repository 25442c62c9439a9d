#include "peha/experiments/e1_gravity/e1_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

E1RealtimeResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const runtime::RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const auto backend = mfb::make_board_backend(*scenario.link, options.board, scenario.period_s, sim::one_dof_rig_joint_names());
  E1RealtimeResult res;
  {
    runtime::RealtimeHarness harness(*backend, supervisor_params(*scenario.link, options), options, scenario.period_s, scenario.duration_s, c.name,
                            options.dir / fmt::format("e1_{}.csv", c.name), e1_log_columns(),
                            {fmt::format("case: {} (payload {} kg) on the MFB at udp://{}", c.name, c.payload_kg, options.board.to_string()),
                             fmt::format("session {:08x}; plant_* and finger columns are NaN: the host sees only the board's sensors",
                                         backend->session_id())});
    const runtime::CycleHooks hooks = harness.start();
    res.e1 = run_e1_on(scenario, c, *backend, nullptr, &harness.sink(), hooks);
    harness.finish(res);
    add_link_fault_check(res, res.e1.verdict);
    res.e1.within_limits = res.e1.verdict.passed();
    res.link = backend->stats();
  }
  return res;
}

}  // namespace peha::experiments
