#include "peha/experiments/e4_goniometer/goniometer_realtime.hpp"

#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

namespace peha::experiments {

GoniometerRealtimeResult run_goniometer_realtime(const ArmScenario& scenario, std::size_t movement, GoniometerVariant variant,
                                                 const runtime::RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const auto backend = mfb::make_board_backend(*scenario.link, options.board, scenario.period_s, arm_joint_names(scenario));
  for (const int j : scenario.goniometer.joints) {
    if (!backend->channel_map().has_goniometer(j)) {
      throw std::runtime_error(fmt::format("{}: no {}.goniometer channel: E4 on the board reads the person's goniometer there",
                                           scenario.link->channel_map.string(), arm_joint_names(scenario)[static_cast<std::size_t>(j)]));
    }
  }
  const ArmScenario::Goniometer::Movement& m = scenario.goniometer.movements.at(movement);
  // The movement's length is the protocol's; its samples come from the board.
  const double duration_s = goniometer_run_duration_s(scenario, synthesize_goniometer(scenario.goniometer, m, scenario.seed));
  GoniometerRealtimeResult res;
  {
    runtime::RealtimeHarness harness(*backend, supervisor_params(*scenario.link, options), options, scenario.period_s, duration_s, m.name + "/" + to_string(variant),
                            options.dir / fmt::format("e4_{}_{}.csv", m.name, to_string(variant)), goniometer_log_columns(scenario),
                            {fmt::format("case: E4 movement {}, variant {}, on the MFB at udp://{}, session {:08x}", m.name,
                                         to_string(variant), options.board.to_string(), backend->session_id()),
                             "person_elbow_deg is the goniometer's reading (the board knows no more); plant_* columns are NaN"});
    const runtime::CycleHooks hooks = harness.start();
    mfb::UdpBackend& b = *backend;
    std::vector<GoniometerSource> readings;  // each driven joint's goniometer channel
    for (const int j : scenario.goniometer.joints) readings.push_back([&b, j](double) { return b.goniometer_rad(j); });
    res.goniometer = run_goniometer_on(scenario, m.name, variant, duration_s, b, nullptr, readings, {}, &harness.sink(), hooks);
    harness.finish(res);
    add_link_fault_check(res, res.goniometer.verdict);
    res.goniometer.within_limits = res.goniometer.verdict.passed();
    res.link = backend->stats();
  }
  return res;
}

}  // namespace peha::experiments
