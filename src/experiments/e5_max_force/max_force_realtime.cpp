#include "peha/experiments/e5_max_force/max_force_realtime.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace peha::experiments {

E5RealtimeResult run_e5_realtime(const E5Scenario& scenario, const E5Case& c, const HardwareRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  E5RealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      e5_hardware(scenario, c), scenario.lifecycle, options,
      {c.name, scenario.duration_s, options.dir / fmt::format("e5_{}.csv", c.name), e5_log_columns(),
       {fmt::format("case: {} (clamp at {} deg)", c.name, models::rad_to_deg(c.locked_angle_rad)),
        "plant_* columns are NaN: the host sees only the board's sensors"}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        res.e5 = run_e5_on(scenario, c, *hw.backend, nullptr, &sink, hooks);
        return res.e5.verdict;
      });
  res.e5.passed = res.e5.verdict.passed();
  return res;
}

}  // namespace peha::experiments
