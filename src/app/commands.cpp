#include "peha/app/commands.hpp"

#include "peha/runtime/e1_gravity.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>

namespace peha::app {
namespace {

std::string default_run_name(const std::filesystem::path& config) {
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  return fmt::format("{}-{:%Y%m%d-%H%M%S}", config.stem().string(), now);
}

std::string find_python() {
  // Debian's interpreter carries numpy/matplotlib; the python3 first on PATH may not.
  return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}

std::filesystem::path plot_tool() {
  const std::filesystem::path tool = std::filesystem::path(PEHA_SOURCE_DIR) / "tools" / "plot_run.py";
  return tool;
}

void write_summary(const std::filesystem::path& path, const std::vector<runtime::E1Result>& results) {
  std::ofstream out(path);
  out << "case,payload_kg,release,release_time_s,angle_at_release_deg,drift_deg,max_excursion_deg,"
         "peak_finger_force_N,peak_agonist_force_N,peak_antagonist_force_N,min_wire_tension_N,"
         "max_pressure_MPa,peak_motor_torque_Nm,min_angle_deg,max_angle_deg,within_limits,realtime_factor\n";
  for (const auto& r : results) {
    for (const auto& rel : r.releases) {
      out << fmt::format("{},{},{},{:.3f},{:.3f},{:.4f},{:.4f},{:.2f},{:.1f},{:.1f},{:.2f},{:.4f},{:.3f},{:.2f},{:.2f},{},{:.2f}\n",
                         r.case_name, r.payload_kg, rel.push, rel.time_s, rel.angle_deg, rel.drift_deg,
                         rel.max_excursion_deg, r.peak_finger_force_N, r.peak_muscle_force_N[0],
                         r.peak_muscle_force_N[1], r.min_wire_tension_N, r.max_pressure_MPa,
                         r.peak_motor_torque_Nm, r.min_angle_deg, r.max_angle_deg, r.within_limits ? 1 : 0,
                         r.realtime_factor);
    }
  }
}

int run_e1(const RunOptions& options, const config::Document& doc) {
  runtime::E1Scenario scenario = runtime::read_e1(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  std::vector<runtime::E1Case> cases;
  for (const auto& c : scenario.cases) {
    if (options.only_case.empty() || c.name == options.only_case) cases.push_back(c);
  }
  if (cases.empty()) {
    fmt::print(stderr, "error: no case named '{}' in {}\n", options.only_case, doc.name());
    return 2;
  }

  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const std::filesystem::path dir = options.out_root / run_name;
  std::filesystem::create_directories(dir);
  {
    // The exact file the run used, with where it came from: its relative paths resolve there.
    std::ifstream in(options.config);
    std::ofstream out(dir / "config.yaml");
    out << fmt::format("# peha run copy of {}\n# relative paths resolve against {}\n# seed used: {}\n",
                       std::filesystem::absolute(options.config).string(),
                       std::filesystem::absolute(options.config).parent_path().string(), scenario.seed)
        << in.rdbuf();
  }

  fmt::print("peha run: {}\n  {}\n  {} case(s), {:.1f} s simulated each, seed {}, output {}\n", doc.name(),
             scenario.description, cases.size(), scenario.duration_s, scenario.seed, dir.string());
  std::vector<runtime::E1Result> results;
  const auto rows = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s)) + 1;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    fmt::print("  [{}/{}] {} ... ", i + 1, cases.size(), cases[i].name);
    std::fflush(stdout);
    runtime::CsvLog log(runtime::e1_log_columns(), rows);
    results.push_back(runtime::run_e1_case(scenario, cases[i], &log));
    const auto& r = results.back();
    const std::filesystem::path log_path = dir / fmt::format("e1_{}.csv", cases[i].name);
    log.write(log_path, {fmt::format("case: {} ({} kg payload)", cases[i].name, cases[i].payload_kg),
                         fmt::format("config: {}", options.config.string()),
                         fmt::format("seed: {}", scenario.seed),
                         "pressures gauge; plant_* columns are simulator truth the controller never sees"});
    fmt::print("{:.1f} s simulated at {:.1f}x real time -> {}\n", r.simulated_s, r.realtime_factor, log_path.string());
  }
  write_summary(dir / "summary.csv", results);

  fmt::print("\n{:<15} {:<12} {:>9} {:>10} {:>11} {:>11} {:>10} {:>10} {:>9} {:>6}\n", "case", "release",
             "angle/deg", "drift/deg", "excurs/deg", "finger/N", "F_ago/N", "F_ant/N", "T_min/N", "RTF");
  bool safe = true;
  for (const auto& r : results) {
    for (const auto& rel : r.releases) {
      fmt::print("{:<15} {:<12} {:>9.2f} {:>10.3f} {:>11.3f} {:>11.1f} {:>10.1f} {:>10.1f} {:>9.2f} {:>6.1f}\n",
                 r.case_name, rel.push, rel.angle_deg, rel.drift_deg, rel.max_excursion_deg, r.peak_finger_force_N,
                 r.peak_muscle_force_N[0], r.peak_muscle_force_N[1], r.min_wire_tension_N, r.realtime_factor);
    }
    safe = safe && r.within_limits;
    fmt::print("{:<15} safety: peak PAM force {:.0f} N (limit 2000), min wire tension {:.2f} N (> 0), max pressure "
               "{:.3f} MPa, peak motor {:.2f} Nm, angle {:.1f}..{:.1f} deg: {}\n",
               "", std::max(r.peak_muscle_force_N[0], r.peak_muscle_force_N[1]), r.min_wire_tension_N,
               r.max_pressure_MPa, r.peak_motor_torque_Nm, r.min_angle_deg, r.max_angle_deg,
               r.within_limits ? "OK" : "VIOLATED");
    fmt::print("{:<15} limits layer shaped the command in: pressure band {} cycles, rate {}, joint range {}, "
               "motor rating {}, non-finite {}\n",
               "", r.limit_counts[2], r.limit_counts[3], r.limit_counts[1], r.limit_counts[4], r.limit_counts[0]);
  }
  fmt::print("\nwritten: {}/summary.csv, config.yaml, e1_<case>.csv\n", dir.string());

  if (options.plot) {
    std::fflush(stdout);  // the plotter writes to the same terminal
    const std::string cmd = fmt::format("'{}' '{}' '{}' --title '{}'", find_python(), plot_tool().string(),
                                        dir.string(), "E1 gravity compensation, one-DOF PEHA rig");
    if (std::system(cmd.c_str()) != 0) {
      fmt::print(stderr, "warning: plotting failed (needs /usr/bin/python3 with matplotlib: run scripts/install-deps.sh); "
                         "the logs are complete\n");
    }
  }
  std::error_code ec;
  std::filesystem::remove(options.out_root / "latest", ec);
  std::filesystem::create_directory_symlink(run_name, options.out_root / "latest", ec);
  return safe ? 0 : 3;
}

}  // namespace

int run(const RunOptions& options) {
  try {
    const config::Document doc = config::Document::load_file(options.config);
    return run_e1(options, doc);
  } catch (const config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}

int check_config(const std::filesystem::path& config) {
  try {
    const config::Document doc = config::Document::load_file(config);
    const runtime::E1Scenario s = runtime::read_e1(doc);
    sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
    fmt::print("{}: OK\n  experiment gravity_compensation_1dof: {}\n  {} case(s), {} s at {} Hz, {} finger push(es), "
               "plant model {}\n",
               config.string(), s.description, s.cases.size(), s.duration_s, 1.0 / s.period_s,
               s.plant.finger.pushes.size(), s.plant.model_file.string());
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  }
}

}  // namespace peha::app
