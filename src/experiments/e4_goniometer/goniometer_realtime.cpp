#include "peha/experiments/e4_goniometer/goniometer_realtime.hpp"

#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

GoniometerRealtimeResult run_goniometer_realtime(const ArmScenario& scenario, std::size_t movement, GoniometerVariant variant,
                                                 const HardwareRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  if (options.backend.kind != hardware::BackendKind::kBoards) {
    throw std::invalid_argument("E4 on hardware reads the person's goniometer from the board: give --backend udp://...");
  }
  {  // checked before the run: the person's goniometer is an AD channel of the (one) board
    const mfb::ChannelMap map = mfb::read_channel_map(config::Document::load_file(scenario.link->channel_map), arm_joint_names(scenario));
    for (const int j : scenario.goniometer.joints) {
      if (!map.has_goniometer(j)) {
        throw std::runtime_error(fmt::format("{}: no {}.goniometer channel: E4 on the board reads the person's goniometer there",
                                             scenario.link->channel_map.string(), arm_joint_names(scenario)[static_cast<std::size_t>(j)]));
      }
    }
  }
  const ArmScenario::Goniometer::Movement& m = scenario.goniometer.movements.at(movement);
  // The movement's length is the protocol's; its samples come from the board.
  const double duration_s = goniometer_run_duration_s(scenario, synthesize_goniometer(scenario.goniometer, m, scenario.seed));
  GoniometerRealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      goniometer_hardware(scenario, scenario.plant), scenario.lifecycle, options,
      {m.name + "/" + to_string(variant), duration_s, options.dir / fmt::format("e4_{}_{}.csv", m.name, to_string(variant)),
       goniometer_log_columns(scenario),
       {fmt::format("case: E4 movement {}, variant {}", m.name, to_string(variant)),
        "person_elbow_deg is the goniometer's reading (the board knows no more); plant_* columns are NaN"}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        const mfb::UdpBackend& board = hw.boards->board(0);  // one board: arm_hardware(..., one_board)
        std::vector<GoniometerSource> readings;                // each driven joint's goniometer channel
        for (const int j : scenario.goniometer.joints) readings.push_back([&board, j](double) { return board.goniometer_rad(j); });
        res.goniometer = run_goniometer_on(scenario, m.name, variant, duration_s, *hw.backend, nullptr, readings, {}, &sink, hooks);
        return res.goniometer.verdict;
      });
  res.goniometer.within_limits = res.goniometer.verdict.passed();
  return res;
}

}  // namespace peha::experiments
