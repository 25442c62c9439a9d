#include "peha/experiments/e3_postures/postures_report.hpp"

#include "peha/experiments/e3_postures/postures_realtime.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace peha::experiments {

void write_postures_summary(const std::filesystem::path& path, const PosturesResult& r, double observe_s) {
  std::ofstream summary(path);
  summary << "posture,target_sfe_deg,target_efe_deg,released_sfe_deg,released_efe_deg,drift_sfe_deg,drift_efe_deg,"
             "max_excursion_sfe_deg,max_excursion_efe_deg,stop_distance_sfe_deg,stop_distance_efe_deg,max_drift_deg,"
             "stop_margin_deg,static_torque_error_sfe_pct,static_torque_error_efe_pct,gravity_torque_sfe_Nm,gravity_torque_efe_Nm,"
             "model_gravity_error_sfe_pct,model_gravity_error_efe_pct,max_static_torque_error_pct,min_wire_tension_N,min_wire_tension_limit_N,within_limits\n";
  const safety::VerdictThresholds& t = r.verdict.thresholds;
  double tension_limit = 0;
  for (const auto& c : r.verdict.checks) {
    if (c.figure.ends_with("lowest wire tension")) tension_limit = std::max(tension_limit, c.limit);
  }
  fmt::print("\n{:<15} {:>15} {:>17} {:>19} {:>19} {:>21} {:>15}\n", "posture", "target SFE/EFE", "released SFE/EFE",
             fmt::format("drift {:.0f} s SFE/EFE", observe_s), "max excursion", "static error SFE/EFE", "model G error");
  for (const auto& p : r.postures) {
    fmt::print("{:<15} {:>7.1f} {:>7.1f} {:>8.2f} {:>8.2f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f} deg {:>7.1f} {:>7.1f} {:>7.1f} {:>7.1f} % of gravity\n",
               p.name, p.target_deg[0], p.target_deg[1], p.released_deg[0], p.released_deg[1], p.drift_deg[0], p.drift_deg[1],
               p.max_excursion_deg[0], p.max_excursion_deg[1], p.static_torque_error_pct[0], p.static_torque_error_pct[1],
               p.model_gravity_error_pct[0], p.model_gravity_error_pct[1]);
    summary << fmt::format("{},{:.3f},{:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{:.3f},{:.3g},{:.3g},{:.2f},{:.2f},{:.3f},{:.3f},"
                           "{:.2f},{:.2f},{:.3g},{:.2f},{:.2f},{}\n",
                           p.name, p.target_deg[0], p.target_deg[1], p.released_deg[0], p.released_deg[1], p.drift_deg[0],
                           p.drift_deg[1], p.max_excursion_deg[0], p.max_excursion_deg[1], p.stop_distance_deg[0],
                           p.stop_distance_deg[1], t.max_drift_deg, t.stop_margin_deg, p.static_torque_error_pct[0],
                           p.static_torque_error_pct[1], p.gravity_torque_Nm[0], p.gravity_torque_Nm[1], p.model_gravity_error_pct[0],
                           p.model_gravity_error_pct[1], t.max_static_torque_error_pct,
                           r.min_wire_tension_N, tension_limit, r.within_limits ? 1 : 0);
  }
}

int run_postures_experiment(const config::Document& doc, const ArmScenario& scenario_read, const RunRequest& request,
                            std::optional<runtime::RealtimeRunOptions> realtime) {
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
    fmt::print("  on the board at udp://{} in real time\n", realtime->board.to_string());
    std::fflush(stdout);
    rr = run_postures_realtime(scenario, *realtime);
    r = rr->postures;
  } else {
    runtime::CsvLog log(arm_log_columns(), static_cast<std::size_t>(duration_s / scenario.period_s) + 2);
    for (const sim::PlantFault& f : scenario.faults) fmt::print("  plant fault: {}\n", sim::describe(f, arm_joint_names(scenario)));
    r = run_postures(scenario, &log);
    log.write(dir / "e3_postures.csv", {"case: E3 postures, right arm with mannequin arm",
                                        fmt::format("config: {}; seed {}", request.config.string(), scenario.seed),
                                        "plant_* columns are simulator truth the controller never sees"});
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
