#include "peha/experiments/e3_postures/postures_report.hpp"

#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace peha::experiments {

void write_postures_summary(const std::filesystem::path& path, const PosturesResult& r, double observe_s) {
  std::ofstream summary(path);
  summary << "posture,joint,target_deg,released_deg,drift_deg,max_excursion_deg,stop_distance_deg,static_torque_error_pct,"
             "gravity_torque_Nm,model_gravity_error_pct,max_drift_deg,stop_margin_deg,max_static_torque_error_pct,min_wire_tension_N,"
             "min_wire_tension_limit_N,within_limits\n";
  const safety::VerdictThresholds& t = r.verdict.thresholds;
  double tension_limit = 0;
  for (const auto& c : r.verdict.checks) {
    if (c.figure.ends_with("lowest wire tension")) tension_limit = std::max(tension_limit, c.limit);
  }
  fmt::print("\n{:<15} {:<7} {:>7} {:>9} {:>11} {:>14} {:>13} {:>14}\n", "posture", "joint", "target", "released",
             fmt::format("drift {:.0f} s", observe_s), "max excursion", "static error", "model G error");
  for (const auto& p : r.postures) {
    for (const PostureJointResult& j : p.joints) {
      fmt::print("{:<15} {:<7} {:>7.1f} {:>9.2f} {:>11.3f} {:>10.3f} deg {:>11.1f} % {:>12.1f} % of gravity\n", p.name, j.joint,
                 j.target_deg, j.released_deg, j.drift_deg, j.max_excursion_deg, j.static_torque_error_pct, j.model_gravity_error_pct);
      summary << fmt::format("{},{},{:.3f},{:.3f},{:.4f},{:.4f},{:.3f},{:.2f},{:.3f},{:.2f},{:.3g},{:.3g},{:.3g},{:.2f},{:.2f},{}\n", p.name,
                             j.joint, j.target_deg, j.released_deg, j.drift_deg, j.max_excursion_deg, j.stop_distance_deg,
                             j.static_torque_error_pct, j.gravity_torque_Nm, j.model_gravity_error_pct, t.max_drift_deg, t.stop_margin_deg,
                             t.max_static_torque_error_pct, r.min_wire_tension_N, tension_limit, r.within_limits ? 1 : 0);
    }
  }
}

namespace {

/// E3 in process through the hardware door: on the simulated arm (sim:) or a recorded E3 log fed to
/// the controller (replay:), which also writes the commands beside the recorded ones (replay_postures.csv).
PosturesResult run_in_process(const ArmScenario& scenario, const RunRequest& request, const std::filesystem::path& dir) {
  const hardware::BackendUri uri = hardware::BackendUri::parse(request.backend);  // checked before the run directory was made
  const hardware::Hardware hw = hardware::open_backend(uri, postures_hardware(scenario));
  const double duration_s = postures_duration_s(scenario);
  runtime::CsvLog log(arm_log_columns(scenario), static_cast<std::size_t>(duration_s / scenario.period_s) + 2);
  std::vector<std::string> comments = {fmt::format("case: E3 postures, {}", scenario.description),
                                       fmt::format("config: {}; seed {}", request.config.string(), scenario.seed),
                                       "plant_* columns are simulator truth the controller never sees"};
  if (hw.replay) {
    comments.back() = "replayed from " + uri.replay_log.string() + ": the sensors are the log's, plant_* columns NaN";
  } else {
    for (const sim::PlantFault& f : scenario.faults) fmt::print("  plant fault: {}\n", sim::describe(f, arm_joint_names(scenario)));
  }
  const PosturesResult r = run_postures_on(scenario, *hw.backend, dynamic_cast<const sim::ArmBackend*>(hw.backend.get()), &log);
  log.write(dir / "e3_postures.csv", comments);
  if (hw.replay) print_replay(*hw.replay, dir / "replay_postures.csv");
  return r;
}

}  // namespace

int run_postures_experiment(const config::Document& doc, const ArmScenario& scenario_read, const RunRequest& request,
                            std::optional<HardwareRunOptions> realtime) {
  ArmScenario scenario = scenario_read;
  for (const std::string& spec : request.faults) {
    try {
      scenario.faults.push_back(sim::parse_fault_spec(spec, arm_joint_names(scenario), postures_duration_s(scenario)));
    } catch (const std::invalid_argument& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return 2;
    }
  }
  const std::filesystem::path dir = request.open_run_dir(scenario.seed);
  const double duration_s = postures_duration_s(scenario);
  fmt::print("peha run: {} --experiment postures (E3)\n  {}\n  {} postures, {:.0f} s simulated, seed {}, output {}\n",
             doc.name(), scenario.description, scenario.postures.size(), duration_s, scenario.seed, dir.string());
  PosturesResult r;
  std::optional<PosturesRealtimeResult> rr;
  if (realtime) {
    realtime->dir = dir;
    if (scenario.link->boards.size() == 1) {
      fmt::print("  on {} in real time\n", realtime->backend.describe());
    } else {
      const std::vector<io::UdpEndpoint> at = mfb::board_endpoints(*scenario.link, realtime->backend.boards);
      fmt::print("  on {} boards in real time:", at.size());
      for (std::size_t b = 0; b < at.size(); ++b) fmt::print(" {} at udp://{}{}", scenario.link->boards[b].name, at[b].to_string(), b + 1 < at.size() ? "," : "\n");
    }
    std::fflush(stdout);
    rr = run_postures_realtime(scenario, *realtime);
    r = rr->postures;
  } else {
    r = run_in_process(scenario, request, dir);
  }
  if (r.faults) fmt::print("  SUPERVISOR FAULT: {}\n", r.fault_reason);
  write_postures_summary(dir / "summary.csv", r, scenario.observe_s);  // closed: the plotter reads it next
  fmt::print("verdict (thresholds from the verdict: section):\n{}verdict: {}; peak operator torque {:.1f} Nm\n"
             "real-time factor {:.1f}; written {}/e3_postures.csv, summary.csv, config.yaml\n",
             r.verdict.describe_all(), r.within_limits ? "OK" : "VIOLATED", r.peak_operator_torque_Nm, r.realtime_factor,
             dir.string());
  if (rr) print_realtime(*rr, dir / "timing");
  if (request.plot) plot_with("plot_arm.py", dir);
  return r.within_limits ? 0 : 3;
}

}  // namespace peha::experiments
