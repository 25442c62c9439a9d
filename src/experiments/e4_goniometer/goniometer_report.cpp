#include "peha/experiments/e4_goniometer/goniometer_report.hpp"

#include "peha/control/butterworth.hpp"
#include "peha/experiments/e4_goniometer/goniometer_realtime.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <string>

namespace peha::experiments {
namespace {

constexpr GoniometerVariant kVariants[] = {GoniometerVariant::kOpenLoop, GoniometerVariant::kFeedback};

/// The scenario's movement names, comma-separated.
std::string movement_names(const ArmScenario::Goniometer& g) {
  std::string names;
  for (const auto& m : g.movements) names += (names.empty() ? "" : ", ") + m.name;
  return names;
}

/// The index of the movement `name`, or movements.size().
std::size_t find_movement(const ArmScenario::Goniometer& g, const std::string& name) {
  std::size_t index = g.movements.size();
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    if (g.movements[i].name == name) index = i;
  }
  return index;
}

/// The person's movements, each as one trace per driven joint: the recording (the same on every driven
/// joint, inside each one's range), or the synthetic movements (only `only_case` if given; each drawn
/// from seed + its index, as in a run of all). Empty (after a message): no such movement.
std::vector<std::vector<GoniometerTrace>> person_traces(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request) {
  const auto& g = scenario.goniometer;
  std::vector<std::vector<GoniometerTrace>> traces;
  if (!request.goniometer_csv.empty()) {
    double lo = -std::numbers::pi, hi = std::numbers::pi;
    for (const int j : g.joints) {
      lo = std::max(lo, scenario.limits.joints[static_cast<std::size_t>(j)].min_angle_rad);
      hi = std::min(hi, scenario.limits.joints[static_cast<std::size_t>(j)].max_angle_rad);
    }
    traces.emplace_back(g.joints.size(), read_goniometer_csv(request.goniometer_csv, g.sample_rate_Hz, lo, hi));
    return traces;
  }
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    if (request.only_case.empty() || g.movements[i].name == request.only_case) {
      traces.push_back(synthesize_goniometers(g, g.movements[i], scenario.seed + i));
    }
  }
  if (traces.empty()) {
    fmt::print(stderr, "error: no goniometer movement named '{}' in {} (movements: {})\n", request.only_case, doc.name(),
               movement_names(g));
  }
  return traces;
}

/// "R_EFE, L_EFE": the driven joints; "R_SAA 0, R_SFE -90 deg": the held posture.
std::string driven_names(const ArmScenario& scenario) {
  std::vector<std::string> names;
  for (const int j : scenario.goniometer.joints) names.push_back(arm_joint_names(scenario)[static_cast<std::size_t>(j)]);
  return fmt::format("{}", fmt::join(names, ", "));
}
std::string held_posture(const ArmScenario& scenario) {
  std::vector<std::string> held;
  for (std::size_t i = 0; i < scenario.goniometer.held_rad.size(); ++i) {
    const double q = scenario.goniometer.held_rad[i];
    if (!std::isnan(q)) held.push_back(fmt::format("{} {:.0f}", arm_joint_names(scenario)[i], models::rad_to_deg(q)));
  }
  return held.empty() ? "none" : fmt::format("{} deg", fmt::join(held, ", "));
}

int run_in_process(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request) {
  const auto& g = scenario.goniometer;
  const std::vector<std::vector<GoniometerTrace>> movements = person_traces(doc, scenario, request);
  if (movements.empty()) return 2;
  const hardware::BackendUri uri = hardware::BackendUri::parse(request.backend);  // checked before: sim: or replay:
  const bool replay = uri.kind == hardware::BackendKind::kReplay;
  if (replay && movements.size() > 1) {
    fmt::print(stderr, "error: --backend {} replays one movement's log: give --case NAME ({})\n", uri.text, movement_names(g));
    return 2;
  }
  const std::filesystem::path dir = request.open_run_dir(scenario.seed);
  fmt::print("peha run: {} --experiment goniometer (E4)\n  goniometer {:.0f} Hz, noise {:.2f} deg, Butterworth order {} at {:.1f} Hz "
             "(group delay {:.1f} ms) on {}; held on gravity compensation: {}\n  {}\n",
             doc.name(), g.sample_rate_Hz, models::rad_to_deg(g.noise_rad), g.filter_order, g.cutoff_Hz,
             control::group_delay_s(control::design_butterworth_lowpass(g.filter_order, g.cutoff_Hz, g.sample_rate_Hz), 0.0) * 1e3,
             driven_names(scenario), held_posture(scenario),
             request.goniometer_csv.empty() ? "synthetic person: " + std::to_string(movements.size()) + " movement(s)"
                                            : "recording: " + request.goniometer_csv.string() +
                                                  (g.joints.size() > 1 ? " (on every driven joint)" : ""));
  std::ofstream summary(dir / "summary.csv");
  summary << "movement,variant,joint,range_deg,rms_error_deg,max_error_deg,delay_ms,rms_error_aligned_deg,peak_torque_cmd_Nm,"
             "joint_min_wire_tension_N,joint_min_wire_tension_limit_N,held_excursion_deg,peak_muscle_force_N,min_wire_tension_N,"
             "min_wire_tension_limit_N,peak_motor_Nm,max_tracking_rms_deg,max_tracking_error_deg,within_limits\n";
  std::vector<GoniometerResult> results;
  const std::vector<std::string> columns = goniometer_log_columns(scenario);
  for (const std::vector<GoniometerTrace>& traces : movements) {
    const GoniometerTrace& trace = traces.front();
    const double duration_s = goniometer_run_duration_s(scenario, trace);
    fmt::print("  {}: {:.1f} s simulated ...\n", trace.name, duration_s);
    std::fflush(stdout);
    runtime::CsvLog log(columns, static_cast<std::size_t>(duration_s / scenario.period_s) + 2);
    for (const auto variant : kVariants) {
      log.clear();
      // Both variants on a replayed log too: the one that recorded it gives its commands back.
      const hardware::Hardware hw = hardware::open_backend(uri, goniometer_hardware(scenario, goniometer_plant_params(scenario, traces)));
      const GoniometerResult r = run_goniometer(scenario, traces, variant, hw, &log);
      log.write(dir / fmt::format("e4_{}_{}.csv", trace.name, to_string(variant)),
                {fmt::format("case: E4 goniometer-driven {}, movement {}, variant {}", driven_names(scenario), trace.name, to_string(variant)),
                 fmt::format("config: {}; seed {}", request.config.string(), scenario.seed),
                 replay ? "replayed from " + uri.replay_log.string() + ": sensors and goniometers are the log's, person_* the goniometer, plant_* NaN"
                        : "person_* is the person's true joint; plant_* columns are simulator truth the controller never sees"});
      if (hw.replay) print_replay(*hw.replay, dir / fmt::format("replay_{}_{}.csv", trace.name, to_string(variant)));
      double tension_limit = 0;
      for (const auto& c : r.verdict.checks) {
        if (c.figure.ends_with("lowest wire tension")) tension_limit = std::max(tension_limit, c.limit);
      }
      for (const GoniometerJointResult& j : r.joints) {
        const safety::Check* own = r.verdict.find(j.joint + " lowest wire tension");
        summary << fmt::format("{},{},{},{:.2f},{:.4f},{:.4f},{:.1f},{:.4f},{:.4f},{:.2f},{:.2f},{:.4f},{:.1f},{:.2f},{:.2f},{:.3f},{:.3g},{:.3g},{}\n",
                               r.name, to_string(r.variant), j.joint, j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3,
                               j.rms_error_aligned_deg, j.peak_torque_command_Nm, j.min_wire_tension_N, own ? own->limit : 0.0,
                               j.held_excursion_deg, r.peak_muscle_force_N, r.min_wire_tension_N, tension_limit, r.peak_motor_torque_Nm,
                               scenario.verdict.max_tracking_rms_deg, scenario.verdict.max_tracking_error_deg, r.within_limits ? 1 : 0);
      }
      results.push_back(r);
    }
    if (request.goniometer_csv.empty() && !replay) {
      for (std::size_t k = 0; k < traces.size(); ++k) {
        // One recording per goniometer; the first keeps the single-joint name.
        const std::string suffix = k == 0 ? "" : "_" + arm_log_prefix(scenario, static_cast<std::size_t>(g.joints[k]));
        write_goniometer_csv(dir / fmt::format("goniometer_{}{}.csv", trace.name, suffix), traces[k]);
      }
    }
  }
  summary.close();  // the plotter reads it next
  const bool safe = print_goniometer_tables(results);
  fmt::print("written: {}/e4_<movement>_<variant>.csv, summary.csv, config.yaml{}\n", dir.string(),
             request.goniometer_csv.empty() && !replay ? ", goniometer_<movement>.csv (replayable with --goniometer-csv)" : "");
  if (request.plot) plot_with("plot_goniometer.py", dir);
  return safe ? 0 : 3;
}

int run_on_board(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request,
                 HardwareRunOptions realtime) {
  const auto& g = scenario.goniometer;
  const std::size_t index = find_movement(g, request.only_case);
  if (index == g.movements.size()) {
    fmt::print(stderr, "error: E4 on the board runs one movement: give --case NAME ({}); the emulator needs --case goniometer_NAME\n",
               movement_names(g));
    return 2;
  }
  const std::filesystem::path dir = request.open_run_dir(scenario.seed);
  realtime.dir = dir;
  fmt::print("peha run: {} --experiment goniometer (E4) on {}, movement {}, both variants\n", doc.name(),
             realtime.backend.describe(), g.movements[index].name);
  std::fflush(stdout);
  bool safe = true;
  std::vector<GoniometerRealtimeResult> results;
  for (const auto variant : kVariants) {
    results.push_back(run_goniometer_realtime(scenario, index, variant, realtime));
    print_realtime(results.back(), dir / fmt::format("timing_{}", to_string(variant)));
  }
  fmt::print("\n{:<10} {:<7} {:>9} {:>10} {:>10} {:>9} {:>12}   (person = the goniometer's reading, exo = the joint's encoder)\n",
             "variant", "joint", "range", "RMS error", "max error", "delay", "RMS aligned");
  for (const auto& rr : results) {
    const auto& r = rr.goniometer;
    safe = safe && r.within_limits && rr.faults == 0;
    for (const GoniometerJointResult& j : r.joints) {
      fmt::print("{:<10} {:<7} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg\n", to_string(r.variant), j.joint,
                 j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3, j.rms_error_aligned_deg);
    }
    fmt::print("{:<10} verdict {}, faults {}\n{}", to_string(r.variant), r.within_limits ? "OK" : "VIOLATED", rr.faults, r.verdict.failures());
  }
  return safe ? 0 : 3;
}

}  // namespace

bool print_goniometer_tables(const std::vector<GoniometerResult>& results) {
  fmt::print("\n{:<10} {:<10} {:<7} {:>9} {:>10} {:>10} {:>9} {:>12} {:>11} {:>11} {:>11} {:>7}\n", "movement", "variant", "joint", "range",
             "RMS error", "max error", "delay", "RMS aligned", "peak tau", "min wire", "held moved", "RTF");
  for (const auto& r : results) {
    for (const GoniometerJointResult& j : r.joints) {
      fmt::print("{:<10} {:<10} {:<7} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg {:>7.2f} Nm {:>9.1f} N {:>7.2f} deg {:>7.1f}\n",
                 r.name, to_string(r.variant), j.joint, j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3,
                 j.rms_error_aligned_deg, j.peak_torque_command_Nm, j.min_wire_tension_N, j.held_excursion_deg, r.realtime_factor);
    }
  }
  bool safe = true;
  for (const auto& r : results) {
    safe = safe && r.within_limits;
    fmt::print("verdict ({}, {}): {}\n{}", r.name, to_string(r.variant), r.within_limits ? "OK" : "VIOLATED",
               r.verdict.describe_all());
  }
  return safe;
}

int run_goniometer_experiment(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request,
                              std::optional<HardwareRunOptions> realtime) {
  if (scenario.goniometer.movements.empty()) {
    fmt::print(stderr, "error: {} has no goniometer: section (E4's sensor, filter and movements; docs/right-arm.md)\n", doc.name());
    return 2;
  }
  return realtime ? run_on_board(doc, scenario, request, *realtime) : run_in_process(doc, scenario, request);
}

}  // namespace peha::experiments
