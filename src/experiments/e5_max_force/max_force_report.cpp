#include "peha/experiments/e5_max_force/max_force_report.hpp"
#include "peha/experiments/e5_max_force/max_force_realtime.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>

namespace peha::experiments {

void write_e5_summary(const std::filesystem::path& path, const std::vector<E5Result>& results) {
  std::ofstream out(path);
  out << "case,muscle,locked_angle_deg,limit_N,peak_force_N,overshoot_N,overshoot_pct,max_overshoot_N,held_force_N,shortfall_N,"
         "max_shortfall_N,peak_truth_force_N,"
         "reach_s,settle_s,max_settle_s,time_at_limit_s,min_time_at_limit_s,at_limit_band_N,pressure_at_limit_MPa,"
         "pressure_cmd_at_limit_MPa,ceiling_share_pct,min_ceiling_share_pct,stop,max_clamp_deflection_deg,from_truth,"
         "missed_samples,passed,failed_checks\n";
  for (const auto& r : results) {
    const safety::VerdictThresholds& t = r.verdict.thresholds;
    std::size_t failed = 0;
    for (const auto& c : r.verdict.checks) failed += !c.passed();
    out << fmt::format("{},{},{:.2f},{:.1f},{:.2f},{:.2f},{:.3f},{:.1f},{:.2f},{:.2f},{:.1f},{:.2f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.1f},{:.4f},{:.4f},"
                       "{:.2f},{:.1f},\"{}\",{:.4f},{},{},{},{}\n",
                       r.case_name, r.muscle, r.locked_angle_deg, r.limit_N, r.peak_force_N, r.overshoot_N, r.overshoot_pct,
                       t.max_force_overshoot_N, r.held_force_N, r.shortfall_N, t.max_force_shortfall_N, r.peak_truth_force_N, r.reach_s, r.settle_s, t.max_settle_s, r.time_at_limit_s,
                       t.min_time_at_limit_s, t.at_limit_band_N, r.pressure_at_limit_MPa, r.pressure_cmd_at_limit_MPa,
                       r.ceiling_share_pct, t.min_ceiling_share_pct, to_string(r.stop), r.max_clamp_deflection_deg,
                       r.from_truth ? 1 : 0, r.missed_samples, r.passed ? 1 : 0, failed);
  }
}

bool print_e5_table(const std::vector<E5Result>& results) {
  bool all = true;
  fmt::print("\n{:<20} {:>9} {:>9} {:>14} {:>9} {:>9} {:>10} {:>9}  {}\n", "case", "limit N", "peak N", "overshoot", "reach s",
             "settle s", "at limit s", "P MPa", "verdict");
  for (const auto& r : results) {
    all = all && r.passed;
    fmt::print("{:<20} {:>9.0f} {:>9.1f} {:>7.1f} N {:>4.2f}% {:>9.2f} {:>9.3f} {:>10.2f} {:>9.3f}  {}\n", r.case_name, r.limit_N,
               r.peak_force_N, r.overshoot_N, r.overshoot_pct, r.reach_s, r.settle_s, r.time_at_limit_s, r.pressure_at_limit_MPa,
               r.passed ? "OK" : "FAIL");
    fmt::print("{:<20} held at {:.1f} N ({:.1f} N short of the ceiling); stopped by: {} ({:.1f} % of the held cycles); peak plant "
               "force {:.1f} N; clamp moved {:.3f} deg\n", "", r.held_force_N, r.shortfall_N,
               to_string(r.stop), r.ceiling_share_pct, r.peak_truth_force_N, r.max_clamp_deflection_deg);
    std::string lines = r.verdict.describe_all();
    fmt::print("{}", lines);
  }
  return all;
}

namespace {

/// One case in process, on the simulated clamped rig or a replayed log (the door's sim: or replay:).
E5Result run_in_process(const E5Scenario& scenario, const E5Case& c, const RunRequest& request, const std::filesystem::path& dir,
                        const hardware::BackendUri& uri) {
  const auto rows = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s)) + 1;
  runtime::CsvLog log(e5_log_columns(), rows);
  const hardware::Hardware hw = hardware::open_backend(uri, e5_hardware(scenario, c));
  E5Result r = run_e5_on(scenario, c, *hw.backend, dynamic_cast<const sim::OneDofRigBackend*>(hw.backend.get()), &log);
  const std::filesystem::path log_path = dir / fmt::format("e5_{}.csv", c.name);
  log.write(log_path, {fmt::format("case: {} (clamp at {} deg)", c.name, r.locked_angle_deg), fmt::format("config: {}", request.config.string()),
                       fmt::format("seed: {}", scenario.seed),
                       "pressures gauge; stop: 0 none, 1 force ceiling, 2 supply, 3 rate limit, 4 supervisor; "
                       "plant_* columns are simulator truth the controller never sees"});
  fmt::print("{:.1f} s {} at {:.1f}x real time -> {}\n", r.simulated_s, hw.replay ? "replayed" : "simulated", r.realtime_factor, log_path.string());
  if (hw.replay) print_replay(*hw.replay, dir / fmt::format("replay_{}.csv", c.name));
  return r;
}

}  // namespace

int run_e5_experiment(const config::Document& doc, const RunRequest& request) {
  E5Scenario scenario = read_e5(doc);
  if (request.seed) scenario.plant.seed = scenario.seed = *request.seed;
  std::vector<E5Case> cases;
  for (const auto& c : scenario.cases) {
    if (request.only_case.empty() || c.name == request.only_case) cases.push_back(c);
  }
  if (cases.empty()) {
    fmt::print(stderr, "error: no case named '{}' in {}\n", request.only_case, doc.name());
    return 2;
  }
  hardware::BackendUri uri;
  std::optional<HardwareRunOptions> realtime;
  if (!check_hardware(doc.name(), scenario.link ? &*scenario.link : nullptr, cases.size(), request, uri, realtime)) return 2;

  const std::filesystem::path dir = request.open_run_dir(scenario.seed);
  fmt::print("peha run: {}\n  {}\n  {} case(s), {} ramped at {} MPa/s from {} s, {:.1f} s each, seed {}, output {}\n", doc.name(),
             scenario.description, cases.size(), scenario.ramp.muscle == 0 ? "agonist" : "antagonist", scenario.ramp.rate_Pa_per_s * 1e-6,
             scenario.ramp.start_s, scenario.duration_s, scenario.seed, dir.string());
  std::vector<E5Result> results;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const E5Case& c = cases[i];
    fmt::print("  [{}/{}] {} ... ", i + 1, cases.size(), c.name);
    std::fflush(stdout);
    if (!realtime) {
      results.push_back(run_in_process(scenario, c, request, dir, uri));
      continue;
    }
    realtime->dir = dir;
    fmt::print("on {} in real time\n", uri.describe());
    std::fflush(stdout);
    const E5RealtimeResult rr = run_e5_realtime(scenario, c, *realtime);
    results.push_back(rr.e5);
    print_realtime(rr, dir / fmt::format("timing_{}", c.name));
  }
  write_e5_summary(dir / "summary.csv", results);
  const bool passed = print_e5_table(results);
  fmt::print("\nwritten: {}/summary.csv, config.yaml, e5_<case>.csv\n", dir.string());
  if (request.plot) plot_with("plot_max_force.py", dir, {"--title", "E5 maximum-force ramp, one-DOF PEHA rig (clamped)"});
  return passed ? 0 : 3;
}

}  // namespace peha::experiments
