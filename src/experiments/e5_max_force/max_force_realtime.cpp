#include "peha/experiments/e5_max_force/max_force_realtime.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace peha::experiments {

E5RealtimeResult run_e5_realtime(const E5Scenario& scenario, const E5Case& c, const runtime::RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const auto backend = mfb::make_board_backend(*scenario.link, options.board, scenario.period_s, sim::one_dof_rig_joint_names());
  E5RealtimeResult res;
  {
    runtime::RealtimeHarness harness(*backend, supervisor_params(*scenario.link, options), options, scenario.period_s, scenario.duration_s,
                                     c.name, options.dir / fmt::format("e5_{}.csv", c.name), e5_log_columns(),
                                     {fmt::format("case: {} (clamp at {} deg) on the MFB at udp://{}", c.name, c.locked_angle_rad * models::kDegPerRad,
                                                  options.board.to_string()),
                                      fmt::format("session {:08x}; plant_* columns are NaN: the host sees only the board's sensors",
                                                  backend->session_id())});
    const runtime::CycleHooks hooks = harness.start();
    res.e5 = run_e5_on(scenario, c, *backend, nullptr, &harness.sink(), hooks);
    harness.finish(res);
    add_link_fault_check(res, res.e5.verdict);
    res.e5.passed = res.e5.verdict.passed();
    res.link = backend->stats();
  }
  return res;
}

}  // namespace peha::experiments
