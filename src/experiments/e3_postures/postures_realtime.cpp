#include "peha/experiments/e3_postures/postures_realtime.hpp"

namespace peha::experiments {

PosturesRealtimeResult run_postures_realtime(const ArmScenario& scenario, const HardwareRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  // One board or several (mfb: boards:), each io joint on its own board's link.
  PosturesRealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      postures_hardware(scenario), scenario.lifecycle, options,
      {"postures", postures_duration_s(scenario), options.dir / "e3_postures.csv", arm_log_columns(scenario),
       {"case: E3 postures", "plant_* and operator_torque columns are NaN: the host sees only the board's sensors"}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        res.postures = run_postures_on(scenario, *hw.backend, nullptr, &sink, hooks);
        return res.postures.verdict;
      });
  res.postures.within_limits = res.postures.verdict.passed();
  return res;
}

}  // namespace peha::experiments
