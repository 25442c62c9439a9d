#include "peha/experiments/e1_gravity/e1_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

E1RealtimeResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const HardwareRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  E1RealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      e1_hardware(scenario, c), scenario.lifecycle, options,
      {c.name, scenario.duration_s, options.dir / fmt::format("e1_{}.csv", c.name), e1_log_columns(),
       {fmt::format("case: {} (payload {} kg)", c.name, c.payload_kg),
        "plant_* and finger columns are NaN: the host sees only the board's sensors"}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        res.e1 = run_e1_on(scenario, c, *hw.backend, nullptr, &sink, hooks);
        return res.e1.verdict;
      });
  res.e1.within_limits = res.e1.verdict.passed();
  return res;
}

E1RecordingRealtimeResult record_e1_muscle_realtime(const E1Scenario& scenario, int index, const HardwareRunOptions& options,
                                                    const std::filesystem::path& cycles_log) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const std::optional<ExcitationParams>& e = scenario.excitation[static_cast<std::size_t>(index)];
  const char* muscle = index == 0 ? "agonist" : "antagonist";
  if (!e) throw config::Error(fmt::format("no calibration.{} section (the excitation to run)", muscle));
  E1RecordingRealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      e1_recording_hardware(scenario, scenario.plant, index), scenario.lifecycle, options,
      {fmt::format("calibration_{}", muscle), e->total_duration_s(), cycles_log, recording_log_columns(),
       {fmt::format("peha record-calibration: muscle {}, every control cycle (the calibration CSV has the 250 Hz rows)", muscle)}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        res.data = record_excitation(*hw.backend, scenario.controller.joint, index == 0 ? +1 : -1, *e, e1_recording_limits(scenario), {},
                                     hooks, &sink);
        return res.verdict;
      });
  return res;
}

}  // namespace peha::experiments
