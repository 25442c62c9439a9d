#include "peha/app/commands.hpp"

#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/control/butterworth.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/experiments/e1_gravity/e1_realtime.hpp"
#include "peha/experiments/e3_postures/postures_realtime.hpp"
#include "peha/experiments/e4_goniometer/goniometer_realtime.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/board_emulator.hpp"
#include "peha/sim/one_dof_rig.hpp"
#include "peha/sim/right_arm.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <chrono>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <unistd.h>
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

/// Progress of long work: a live bar on a terminal, a line per 10 % when the output is a log.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(std::string what) : what_(std::move(what)), tty_(isatty(fileno(stdout)) != 0) {}
  void update(double done, double total, const std::string& detail = "") {
    const int percent = total > 0 ? static_cast<int>(100.0 * done / total) : 100;
    if (tty_) {
      if (percent == last_) return;
      const int filled = percent * 30 / 100;
      fmt::print("\r  {:<14} [{:<30}] {:3d} % {}", what_, std::string(static_cast<std::size_t>(filled), '#'), percent, detail);
      if (percent >= 100) fmt::print("\n");
    } else {
      if (percent / 10 == last_ / 10 && last_ >= 0) return;
      fmt::print("  {:<14} {:3d} % {}\n", what_, percent / 10 * 10, detail);
    }
    last_ = percent;
    std::fflush(stdout);
  }

 private:
  std::string what_;
  bool tty_;
  int last_ = -1;
};

/// Runs a command body and maps what it throws to the exit codes every command documents:
/// 2 for bad input (config or data), 1 for anything else.
template <typename Body>
int with_exit_codes(Body&& body) {
  try {
    return body();
  } catch (const config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  } catch (const calibration::DataError& e) {
    fmt::print(stderr, "data error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}

/// Renders a figure with one of tools/*.py on Debian's Python. A failed plot is a warning: the data
/// files it would read are complete either way.
void plot_with(const char* tool, const std::filesystem::path& dir, const std::string& extra_args = "") {
  std::fflush(stdout);  // the plotter writes to the same terminal
  const std::filesystem::path script = std::filesystem::path(PEHA_SOURCE_DIR) / "tools" / tool;
  const std::string cmd = fmt::format("'{}' '{}' '{}'{}", find_python(), script.string(), dir.string(), extra_args);
  if (std::system(cmd.c_str()) != 0) {
    fmt::print(stderr, "warning: {} failed (needs /usr/bin/python3 with matplotlib: run scripts/install-deps.sh); "
                       "the data in {} are complete\n", tool, dir.string());
  }
}

/// Creates out/<run>/ and copies the config into it, with where it came from (its relative paths
/// resolve there) and the seed used. Called only once everything is loaded and checked.
std::filesystem::path prepare_run_dir(const RunOptions& options, const std::string& run_name, std::uint64_t seed) {
  const std::filesystem::path dir = options.out_root / run_name;
  std::filesystem::create_directories(dir);
  std::ifstream in(options.config);
  std::ofstream out(dir / "config.yaml");
  out << fmt::format("# peha run copy of {}\n# relative paths resolve against {}\n# seed used: {}\n",
                     std::filesystem::absolute(options.config).string(),
                     std::filesystem::absolute(options.config).parent_path().string(), seed)
      << in.rdbuf();
  return dir;
}

void link_latest(const RunOptions& options, const std::string& run_name) {
  std::error_code ec;
  std::filesystem::remove(options.out_root / "latest", ec);
  std::filesystem::create_directory_symlink(run_name, options.out_root / "latest", ec);
}

void write_summary(const std::filesystem::path& path, const std::vector<experiments::E1Result>& results) {
  std::ofstream out(path);
  out << "case,payload_kg,release,release_time_s,angle_at_release_deg,drift_deg,max_excursion_deg,"
         "peak_finger_force_N,peak_agonist_force_N,peak_antagonist_force_N,min_wire_tension_N,"
         "max_pressure_MPa,peak_motor_torque_Nm,min_angle_deg,max_angle_deg,within_limits,"
         "force_tracking_rms_agonist_N,force_tracking_rms_antagonist_N,realtime_factor\n";
  for (const auto& r : results) {
    for (const auto& rel : r.releases) {
      out << fmt::format("{},{},{},{:.3f},{:.3f},{:.4f},{:.4f},{:.2f},{:.1f},{:.1f},{:.2f},{:.4f},{:.3f},{:.2f},{:.2f},{},{:.2f},{:.2f},{:.2f}\n",
                         r.case_name, r.payload_kg, rel.push, rel.time_s, rel.angle_deg, rel.drift_deg,
                         rel.max_excursion_deg, r.peak_finger_force_N, r.peak_muscle_force_N[0],
                         r.peak_muscle_force_N[1], r.min_wire_tension_N, r.max_pressure_MPa,
                         r.peak_motor_torque_Nm, r.min_angle_deg, r.max_angle_deg, r.within_limits ? 1 : 0,
                         r.force_tracking_rms_N[0], r.force_tracking_rms_N[1], r.realtime_factor);
    }
  }
}

/// What a real-time run on the board measured, printed after its experiment's table.
void print_realtime(const experiments::BoardRunResult& rr, const std::filesystem::path& timing_dir) {
  fmt::print("  real-time setup: {}\n", rr.realtime.summary());
  fmt::print("{}\n", rr.timing.table());
  const auto& l = rr.link;
  fmt::print("  link: {} commands sent ({} send failures), states accepted {}, dropped: foreign source {}, foreign "
             "session {}, duplicate {}, stale {}, malformed {}; gaps {}; replies later than receive_timeout {}; cycles without a "
             "new sample {}; implausible samples {}; clamped DA codes {}\n",
             l.commands_sent, l.send_failures, l.received.accepted, l.received.foreign_source, l.received.foreign_session,
             l.received.duplicate, l.received.stale, l.received.malformed, l.received.gaps, l.late_replies, l.replies_missing,
             l.implausible_samples, l.clamped_outputs);
  fmt::print("  log: {} rows written ({} dropped) -> {}; {} fault dump(s); telemetry datagrams {}\n  lifecycle:\n", rr.logged_rows,
             rr.dropped_rows, rr.log_file, rr.fault_dumps.size(), rr.telemetry_datagrams);
  for (const auto& e : rr.lifecycle) fmt::print("    {}\n", e);
  rr.timing.write_csv(timing_dir);
}

/// --backend, --telemetry and the real-time options; nullopt (after a message) when malformed.
std::optional<runtime::RealtimeRunOptions> realtime_options(const RunOptions& options) {
  runtime::RealtimeRunOptions o;
  try {
    o.board = io::parse_udp_endpoint(options.backend);
    if (!options.telemetry.empty()) o.telemetry = io::parse_udp_endpoint(options.telemetry);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return std::nullopt;
  }
  o.realtime.fifo_priority = options.fifo_priority;
  o.realtime.cpu = options.cpu;
  o.recover_after_s = options.recover_after_s.value_or(-1.0);
  return o;
}

int run_e1(const RunOptions& options, const config::Document& doc) {
  experiments::E1Scenario scenario = experiments::read_e1(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  std::vector<experiments::E1Case> cases;
  for (const auto& c : scenario.cases) {
    if (options.only_case.empty() || c.name == options.only_case) cases.push_back(c);
  }
  if (cases.empty()) {
    fmt::print(stderr, "error: no case named '{}' in {}\n", options.only_case, doc.name());
    return 2;
  }

  if (options.force_trim_rate_1ps) scenario.controller.allocation.force_trim_rate_1ps = *options.force_trim_rate_1ps;

  // Variants: the config's own model, or - with calibration files - the calibrated parametric model
  // alone and with its SPGP residual, so the SPGP's effect is measured in the same run.
  struct Variant {
    std::string label;
    experiments::E1Scenario scenario;
  };
  std::vector<Variant> variants;
  const bool calibrated = !options.calibration[0].empty() || !options.calibration[1].empty();
  if (!calibrated) {
    variants.push_back({"", scenario});
  } else {
    experiments::E1Scenario parametric = scenario;
    experiments::E1Scenario with_spgp = scenario;
    bool any_spgp = false;
    for (int i = 0; i < 2; ++i) {
      if (options.calibration[i].empty()) continue;
      const calibration::MuscleCalibration c = calibration::read_calibration(options.calibration[i]);
      calibration::apply_calibration(c, false, i == 0 ? parametric.controller.joint.agonist : parametric.controller.joint.antagonist);
      calibration::apply_calibration(c, true, i == 0 ? with_spgp.controller.joint.agonist : with_spgp.controller.joint.antagonist);
      any_spgp = any_spgp || c.spgp;
      fmt::print("  {} calibration: {} (held-out pressure RMS {:.1f} kPa parametric, {:.1f} kPa with SPGP)\n",
                 i == 0 ? "agonist" : "antagonist", options.calibration[i].string(),
                 c.stats.heldout_rms_parametric_Pa * 1e-3, c.stats.heldout_rms_spgp_Pa * 1e-3);
    }
    variants.push_back({"parametric", parametric});
    if (any_spgp) variants.push_back({"spgp", with_spgp});
  }

  // Over the board: the endpoint and the mfb: section are checked before anything is written.
  std::optional<runtime::RealtimeRunOptions> realtime;
  if (!options.backend.empty()) {
    if (cases.size() > 1) {
      fmt::print(stderr, "error: --backend runs one case against the board's plant: give --case NAME (the board's payload; "
                         "with peha mfb-emulator the same --case); {} has {} cases\n", doc.name(), cases.size());
      return 2;
    }
    realtime = realtime_options(options);
    if (!realtime) return 2;
    if (!scenario.link) {
      fmt::print(stderr, "config error: {}: --backend {} needs an mfb: section (channel map, watchdogs)\n", doc.name(),
                 options.backend);
      return 2;
    }
  }

  // Only now, with everything loaded and checked, does the run leave a trace on disk.
  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const std::filesystem::path dir = prepare_run_dir(options, run_name, scenario.seed);
  fmt::print("peha run: {}\n  {}\n  {} case(s) x {} model(s), {:.1f} s simulated each, seed {}, force trim {}, output {}\n",
             doc.name(), scenario.description, cases.size(), variants.size(), scenario.duration_s, scenario.seed,
             scenario.controller.allocation.force_trim_rate_1ps > 0
                 ? fmt::format("{} /s", scenario.controller.allocation.force_trim_rate_1ps) : std::string("off"),
             dir.string());
  std::vector<experiments::E1Result> results;
  const auto rows = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s)) + 1;
  std::vector<std::pair<experiments::E1Case, const Variant*>> runs;
  for (const auto& c : cases) {
    for (const auto& v : variants) {
      experiments::E1Case named = c;
      if (!v.label.empty()) named.name += "_" + v.label;
      runs.emplace_back(named, &v);
    }
  }
  cases.clear();
  for (const auto& r : runs) cases.push_back(r.first);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    fmt::print("  [{}/{}] {} ... ", i + 1, cases.size(), cases[i].name);
    std::fflush(stdout);
    if (realtime) {
      realtime->dir = dir;
      fmt::print("on the board at udp://{} in real time\n", realtime->board.to_string());
      std::fflush(stdout);
      const experiments::E1RealtimeResult rr = experiments::run_e1_realtime(runs[i].second->scenario, cases[i], *realtime);
      results.push_back(rr.e1);
      print_realtime(rr, dir / fmt::format("timing_{}", cases[i].name));
      continue;
    }
    runtime::CsvLog log(experiments::e1_log_columns(), rows);
    results.push_back(experiments::run_e1_case(runs[i].second->scenario, cases[i], &log));
    const auto& r = results.back();
    const std::filesystem::path log_path = dir / fmt::format("e1_{}.csv", cases[i].name);
    log.write(log_path, {fmt::format("case: {} ({} kg payload)", cases[i].name, cases[i].payload_kg),
                         fmt::format("config: {}", options.config.string()),
                         fmt::format("seed: {}", scenario.seed),
                         "pressures gauge; plant_* columns are simulator truth the controller never sees"});
    fmt::print("{:.1f} s simulated at {:.1f}x real time -> {}\n", r.simulated_s, r.realtime_factor, log_path.string());
  }
  write_summary(dir / "summary.csv", results);

  fmt::print("\n{:<26} {:<10} {:>9} {:>10} {:>11} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>6}\n", "case", "release",
             "angle/deg", "drift/deg", "excurs/deg", "finger/N", "F_ago/N", "F_ant/N", "T_min/N", "Ftrk_ago", "Ftrk_ant",
             "RTF");
  bool safe = true;
  for (const auto& r : results) {
    for (const auto& rel : r.releases) {
      fmt::print("{:<26} {:<10} {:>9.2f} {:>10.3f} {:>11.3f} {:>9.1f} {:>8.1f} {:>8.1f} {:>8.2f} {:>8.1f}N {:>8.1f}N {:>6.1f}\n",
                 r.case_name, rel.push, rel.angle_deg, rel.drift_deg, rel.max_excursion_deg, r.peak_finger_force_N,
                 r.peak_muscle_force_N[0], r.peak_muscle_force_N[1], r.min_wire_tension_N, r.force_tracking_rms_N[0],
                 r.force_tracking_rms_N[1], r.realtime_factor);
    }
    safe = safe && r.within_limits;
    fmt::print("{:<26} safety: peak PAM force {:.0f} N (limit 2000), min wire tension {:.2f} N (> 0), max pressure "
               "{:.3f} MPa, peak motor {:.2f} Nm, angle {:.1f}..{:.1f} deg: {}\n",
               "", std::max(r.peak_muscle_force_N[0], r.peak_muscle_force_N[1]), r.min_wire_tension_N,
               r.max_pressure_MPa, r.peak_motor_torque_Nm, r.min_angle_deg, r.max_angle_deg,
               r.within_limits ? "OK" : "VIOLATED");
    fmt::print("{:<26} limits layer shaped the command in: pressure band {} cycles, rate {}, joint range {}, "
               "motor rating {}, non-finite {}\n",
               "", r.limit_counts[2], r.limit_counts[3], r.limit_counts[1], r.limit_counts[4], r.limit_counts[0]);
  }
  fmt::print("\nwritten: {}/summary.csv, config.yaml, e1_<case>.csv\n", dir.string());

  if (options.plot) plot_with("plot_run.py", dir, " --title 'E1 gravity compensation, one-DOF PEHA rig'");
  link_latest(options, run_name);
  return safe ? 0 : 3;
}

int run_bandwidth(const RunOptions& options, const config::Document& doc, experiments::ArmScenario& scenario) {
  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const std::filesystem::path dir = prepare_run_dir(options, run_name, scenario.seed);
  const auto& b = scenario.bandwidth;
  fmt::print("peha run: {} --experiment bandwidth (E6)\n  {} joint locked at SFE {:.0f} deg, EFE {:.0f} deg; gravity torque "
             "+ {:.1f} Nm sine at {} frequencies, PAM-only and hybrid\n",
             doc.name(), b.joint == 0 ? "shoulder" : "elbow", b.sfe_rad * 180 / std::numbers::pi,
             b.efe_rad * 180 / std::numbers::pi, b.amplitude_Nm, b.frequencies_Hz.size());
  std::vector<experiments::BandwidthResult> results;
  for (bool hybrid : {false, true}) results.push_back(experiments::run_bandwidth(scenario, hybrid));
  std::ofstream csv(dir / "bode.csv");
  csv << "variant,frequency_Hz,gain,gain_dB,phase_deg\n";
  fmt::print("\n{:>8}  {:>10} {:>10}   {:>10} {:>10}\n", "f/Hz", "PAM gain", "PAM phase", "hyb gain", "hyb phase");
  for (std::size_t i = 0; i < b.frequencies_Hz.size(); ++i) {
    const auto& p = results[0].bode[i];
    const auto& h = results[1].bode[i];
    fmt::print("{:>8.2f}  {:>10.3f} {:>9.1f}°   {:>10.3f} {:>9.1f}°\n", p.frequency_Hz, p.gain, p.phase_deg, h.gain, h.phase_deg);
  }
  bool safe = true;
  for (const auto& r : results) {
    for (const auto& p : r.bode) {
      csv << fmt::format("{},{:.4g},{:.6g},{:.4f},{:.3f}\n", r.variant, p.frequency_Hz, p.gain, 20 * std::log10(p.gain), p.phase_deg);
    }
    const bool ok = r.peak_muscle_force_N <= 2000.0 && r.min_wire_tension_N > 0.0;
    safe = safe && ok;
    fmt::print("{:<9} -3 dB bandwidth {}{:.2f} Hz; peak muscle force {:.0f} N, min wire tension {:.1f} N, peak motor {:.2f} Nm: {}\n",
               r.variant, r.reached_3dB ? "" : "> ", r.bandwidth_3dB_Hz, r.peak_muscle_force_N, r.min_wire_tension_N,
               r.peak_motor_torque_Nm, ok ? "OK" : "VIOLATED");
  }
  csv.close();  // the plotter reads it next
  if (options.plot) plot_with("plot_bode.py", dir);
  fmt::print("written: {}/bode.csv, config.yaml\n", dir.string());
  link_latest(options, run_name);
  return safe ? 0 : 3;
}

int run_goniometer(const RunOptions& options, const config::Document& doc, experiments::ArmScenario& scenario) {
  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const auto& g = scenario.goniometer;
  std::vector<experiments::GoniometerTrace> traces;
  if (!options.goniometer_csv.empty()) {
    traces.push_back(experiments::read_goniometer_csv(options.goniometer_csv, g.sample_rate_Hz, scenario.limits.joints[1].min_angle_rad,
                                                  scenario.limits.joints[1].max_angle_rad));
  } else {
    for (std::size_t i = 0; i < g.movements.size(); ++i) traces.push_back(experiments::synthesize_goniometer(g, g.movements[i], scenario.seed + i));
  }
  const std::filesystem::path dir = prepare_run_dir(options, run_name, scenario.seed);
  fmt::print("peha run: {} --experiment goniometer (E4)\n  goniometer {:.0f} Hz, noise {:.2f} deg, Butterworth order {} at {:.1f} Hz "
             "(group delay {:.1f} ms); shoulder at {:.0f} deg on gravity compensation\n  {}\n",
             doc.name(), g.sample_rate_Hz, g.noise_rad * 180 / std::numbers::pi, g.filter_order, g.cutoff_Hz,
             control::group_delay_s(control::design_butterworth_lowpass(g.filter_order, g.cutoff_Hz, g.sample_rate_Hz), 0.0) * 1e3,
             g.sfe_rad * 180 / std::numbers::pi,
             options.goniometer_csv.empty() ? "synthetic person: " + std::to_string(traces.size()) + " movement(s)"
                                            : "recording: " + options.goniometer_csv.string());
  std::ofstream summary(dir / "summary.csv");
  summary << "movement,variant,range_deg,rms_error_deg,max_error_deg,delay_ms,rms_error_aligned_deg,peak_torque_cmd_Nm,"
             "peak_muscle_force_N,min_wire_tension_N,peak_motor_Nm,shoulder_excursion_deg,within_limits\n";
  bool safe = true;
  std::vector<experiments::GoniometerResult> results;
  for (const experiments::GoniometerTrace& trace : traces) {
    const double duration_s = g.settle_s + trace.duration_s() + g.tail_s;
    fmt::print("  {}: {:.1f} s simulated ...\n", trace.name, duration_s);
    std::fflush(stdout);
    runtime::CsvLog log(experiments::goniometer_log_columns(), static_cast<std::size_t>(duration_s / scenario.period_s) + 2);
    for (const auto variant : {experiments::GoniometerVariant::kOpenLoop, experiments::GoniometerVariant::kFeedback}) {
    log.clear();
    const experiments::GoniometerResult r = experiments::run_goniometer(scenario, trace, variant, &log);
    log.write(dir / fmt::format("e4_{}_{}.csv", trace.name, experiments::to_string(variant)),
              {fmt::format("case: E4 goniometer-driven elbow, movement {}, variant {}", trace.name, experiments::to_string(variant)),
               fmt::format("config: {}; seed {}", options.config.string(), scenario.seed),
               "person_* is the person's true elbow; plant_* columns are simulator truth the controller never sees"});
    summary << fmt::format("{},{},{:.2f},{:.4f},{:.4f},{:.1f},{:.4f},{:.4f},{:.1f},{:.2f},{:.3f},{:.4f},{}\n", r.name,
                           experiments::to_string(r.variant), r.range_deg,
                           r.rms_error_deg, r.max_error_deg, r.delay_s * 1e3, r.rms_error_aligned_deg, r.peak_torque_command_Nm,
                           r.peak_muscle_force_N, r.min_wire_tension_N, r.peak_motor_torque_Nm, r.shoulder_excursion_deg,
                           r.within_limits ? 1 : 0);
    safe = safe && r.within_limits;
    results.push_back(r);
    }
    if (options.goniometer_csv.empty()) experiments::write_goniometer_csv(dir / fmt::format("goniometer_{}.csv", trace.name), trace);
  }
  summary.close();  // the plotter reads it next
  fmt::print("\n{:<10} {:<10} {:>9} {:>10} {:>10} {:>9} {:>12} {:>11} {:>11} {:>10}\n", "movement", "variant", "range", "RMS error", "max error",
             "delay", "RMS aligned", "peak tau", "SFE moved", "RTF");
  for (const auto& r : results) {
    fmt::print("{:<10} {:<10} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg {:>7.2f} Nm {:>7.2f} deg {:>10.1f}\n",
               r.name, experiments::to_string(r.variant), r.range_deg, r.rms_error_deg, r.max_error_deg, r.delay_s * 1e3, r.rms_error_aligned_deg, r.peak_torque_command_Nm,
               r.shoulder_excursion_deg, r.realtime_factor);
  }
  for (const auto& r : results) {
    fmt::print("safety ({}, {}): peak muscle force {:.0f} N (limit 2000), min wire tension {:.2f} N (> 0), peak motor {:.2f} Nm: {}\n",
               r.name, experiments::to_string(r.variant), r.peak_muscle_force_N, r.min_wire_tension_N, r.peak_motor_torque_Nm, r.within_limits ? "OK" : "VIOLATED");
  }
  fmt::print("written: {}/e4_<movement>_<variant>.csv, summary.csv, config.yaml{}\n", dir.string(),
             options.goniometer_csv.empty() ? ", goniometer_<movement>.csv (replayable with --goniometer-csv)" : "");
  if (options.plot) plot_with("plot_goniometer.py", dir);
  link_latest(options, run_name);
  return safe ? 0 : 3;
}

int run_goniometer_on_board(const RunOptions& options, const config::Document& doc, experiments::ArmScenario& scenario,
                            runtime::RealtimeRunOptions realtime) {
  const auto& g = scenario.goniometer;
  std::size_t index = g.movements.size();
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    if (g.movements[i].name == options.only_case) index = i;
  }
  if (index == g.movements.size()) {
    std::string names;
    for (const auto& m : g.movements) names += (names.empty() ? "" : ", ") + m.name;
    fmt::print(stderr, "error: E4 on the board runs one movement: give --case NAME ({}); the emulator needs --case goniometer_NAME\n",
               names);
    return 2;
  }
  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const std::filesystem::path dir = prepare_run_dir(options, run_name, scenario.seed);
  realtime.dir = dir;
  fmt::print("peha run: {} --experiment goniometer (E4) on the board at udp://{}, movement {}, both variants\n", doc.name(),
             realtime.board.to_string(), g.movements[index].name);
  std::fflush(stdout);
  bool safe = true;
  std::vector<experiments::GoniometerRealtimeResult> results;
  for (const auto variant : {experiments::GoniometerVariant::kOpenLoop, experiments::GoniometerVariant::kFeedback}) {
    results.push_back(experiments::run_goniometer_realtime(scenario, index, variant, realtime));
    print_realtime(results.back(), dir / fmt::format("timing_{}", experiments::to_string(variant)));
  }
  fmt::print("\n{:<10} {:>9} {:>10} {:>10} {:>9} {:>12}   (person = the goniometer's reading, exo = the elbow encoder)\n",
             "variant", "range", "RMS error", "max error", "delay", "RMS aligned");
  for (const auto& rr : results) {
    const auto& r = rr.goniometer;
    safe = safe && r.within_limits && rr.faults == 0;
    fmt::print("{:<10} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg; safety {}, faults {}\n",
               experiments::to_string(r.variant), r.range_deg, r.rms_error_deg, r.max_error_deg, r.delay_s * 1e3, r.rms_error_aligned_deg,
               r.within_limits ? "OK" : "VIOLATED", rr.faults);
  }
  link_latest(options, run_name);
  return safe ? 0 : 3;
}

int run_arm(const RunOptions& options, const config::Document& doc) {
  if (options.experiment != "postures" && options.experiment != "bandwidth" && options.experiment != "goniometer") {
    fmt::print(stderr, "error: {} is a right-arm scenario: give --experiment postures|goniometer|bandwidth\n", doc.name());
    return 2;
  }
  if (!options.goniometer_csv.empty() && options.experiment != "goniometer") {
    fmt::print(stderr, "error: --goniometer-csv applies to --experiment goniometer only\n");
    return 2;
  }
  experiments::ArmScenario scenario = experiments::read_arm_scenario(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  std::optional<runtime::RealtimeRunOptions> realtime;
  if (!options.backend.empty()) {
    if (options.experiment == "bandwidth") {
      fmt::print(stderr, "error: E6 (--experiment bandwidth) runs in-process only: it needs the joint's true delivered torque, "
                         "which no board sensor measures\n");
      return 2;
    }
    if (!options.goniometer_csv.empty()) {
      fmt::print(stderr, "error: over the board the goniometer is the board's AD channel; --goniometer-csv is for in-process runs\n");
      return 2;
    }
    if (!scenario.link) {
      fmt::print(stderr, "config error: {}: --backend needs an mfb: section (channel map, watchdogs)\n", doc.name());
      return 2;
    }
    realtime = realtime_options(options);
    if (!realtime) return 2;
  }
  if (options.experiment == "bandwidth") return run_bandwidth(options, doc, scenario);
  if (options.experiment == "goniometer") return realtime ? run_goniometer_on_board(options, doc, scenario, *realtime)
                                                          : run_goniometer(options, doc, scenario);
  const std::string run_name = options.run_name.empty() ? default_run_name(options.config) : options.run_name;
  const std::filesystem::path dir = prepare_run_dir(options, run_name, scenario.seed);
  const double duration_s = experiments::postures_duration_s(scenario);
  fmt::print("peha run: {} --experiment postures (E3)\n  {}\n  {} postures, {:.0f} s simulated, seed {}, output {}\n",
             doc.name(), scenario.description, scenario.postures.size(), duration_s, scenario.seed, dir.string());
  experiments::PosturesResult r;
  std::optional<experiments::PosturesRealtimeResult> rr;
  if (realtime) {
    realtime->dir = dir;
    fmt::print("  on the board at udp://{} in real time\n", realtime->board.to_string());
    std::fflush(stdout);
    rr = experiments::run_postures_realtime(scenario, *realtime);
    r = rr->postures;
  } else {
    runtime::CsvLog log(experiments::arm_log_columns(), static_cast<std::size_t>(duration_s / scenario.period_s) + 2);
    r = experiments::run_postures(scenario, &log);
    log.write(dir / "e3_postures.csv", {"case: E3 postures, right arm with mannequin arm",
                                        fmt::format("config: {}; seed {}", options.config.string(), scenario.seed),
                                        "plant_* columns are simulator truth the controller never sees"});
  }
  std::ofstream summary(dir / "summary.csv");
  summary << "posture,target_sfe_deg,target_efe_deg,released_sfe_deg,released_efe_deg,drift_sfe_deg,drift_efe_deg,"
             "max_excursion_sfe_deg,max_excursion_efe_deg\n";
  fmt::print("\n{:<15} {:>15} {:>17} {:>19} {:>19}\n", "posture", "target SFE/EFE", "released SFE/EFE",
             fmt::format("drift {:.0f} s SFE/EFE", scenario.observe_s), "max excursion");
  for (const auto& p : r.postures) {
    fmt::print("{:<15} {:>7.1f} {:>7.1f} {:>8.2f} {:>8.2f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f}   deg\n", p.name, p.target_deg[0],
               p.target_deg[1], p.released_deg[0], p.released_deg[1], p.drift_deg[0], p.drift_deg[1], p.max_excursion_deg[0],
               p.max_excursion_deg[1]);
    summary << fmt::format("{},{:.3f},{:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f}\n", p.name, p.target_deg[0],
                           p.target_deg[1], p.released_deg[0], p.released_deg[1], p.drift_deg[0], p.drift_deg[1],
                           p.max_excursion_deg[0], p.max_excursion_deg[1]);
  }
  summary.close();  // the plotter reads it next
  fmt::print("safety: peak muscle force {:.0f} N (limit 2000), min wire tension {:.2f} N (> 0), peak operator torque "
             "{:.1f} Nm: {}\nreal-time factor {:.1f}; written {}/e3_postures.csv, summary.csv, config.yaml\n",
             r.peak_muscle_force_N, r.min_wire_tension_N, r.peak_operator_torque_Nm, r.within_limits ? "OK" : "VIOLATED",
             r.realtime_factor, dir.string());
  if (rr) print_realtime(*rr, dir / "timing");
  if (options.plot) plot_with("plot_arm.py", dir);
  link_latest(options, run_name);
  return r.within_limits ? 0 : 3;
}

}  // namespace

int run(const RunOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    // The scenario says which kind of exoskeleton it describes.
    config::Map root = doc.root();
    if (root.has("experiment") && root.string("experiment") == "right_arm") return run_arm(options, doc);
    if (!options.experiment.empty()) {
      fmt::print(stderr, "error: --experiment applies to right-arm scenarios; {} is a one-DOF rig scenario\n", doc.name());
      return 2;
    }
    return run_e1(options, doc);
  });
}

int record_calibration(const RecordOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    experiments::E1Scenario scenario = experiments::read_e1(doc);
    const int index = options.muscle == "agonist" ? 0 : 1;
    if (!scenario.excitation[index]) {
      fmt::print(stderr, "config error: {}: no calibration.{} section (the excitation to run)\n", doc.name(),
                 options.muscle);
      return 2;
    }
    const experiments::ExcitationParams& e = *scenario.excitation[index];
    sim::OneDofRigParams plant_params = scenario.plant;
    plant_params.payload_kg = e.payload_kg;
    plant_params.finger.pushes.clear();
    if (options.seed) plant_params.seed = *options.seed;
    sim::OneDofRigBackend plant(plant_params);
    fmt::print("peha record-calibration: {} of the simulated rig ({}), {:.0f} s at {:.0f} Hz\n"
               "  triangle {:.2f}..{:.2f} MPa, period {:.1f} s; other muscle {:.2f}..{:.2f} MPa (antiphase); payload {} kg\n",
               options.muscle, doc.name(), e.duration_s, e.sample_rate_Hz, e.min_pressure_Pa * 1e-6,
               e.max_pressure_Pa * 1e-6, e.period_s, e.other_pressure_at_min_Pa * 1e-6, e.other_pressure_Pa * 1e-6,
               e.payload_kg);
    const calibration::Dataset data = experiments::record_excitation(
        plant, scenario.controller.joint, index == 0 ? +1 : -1, e, scenario.limits,
        [&, bar = std::make_shared<ProgressPrinter>("recording")](double f) { bar->update(f, 1.0); });
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    calibration::write_dataset(
        options.out, data,
        {fmt::format("peha record-calibration: muscle {} of the simulated one-DOF rig", options.muscle),
         fmt::format("config: {}; seed {}", options.config.string(), plant_params.seed),
         "contraction = rigid-wire contraction from the joint encoder with the controller's nominal geometry",
         "force_N = load cell at the muscle; pressure_MPa = valve pressure sensor (gauge)"});
    auto span = [](const std::vector<double>& v) {
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      return std::pair{*lo, *hi};
    };
    const auto [p0, p1] = span(data.pressure_Pa);
    const auto [f0, f1] = span(data.force_N);
    const auto [e0, e1] = span(data.contraction);
    fmt::print("  {} rows -> {}\n  pressure {:.3f}..{:.3f} MPa, force {:.0f}..{:.0f} N, contraction {:.3f}..{:.3f}\n",
               data.size(), options.out.string(), p0 * 1e-6, p1 * 1e-6, f0, f1, e0, e1);
    return 0;
  });
}

namespace {


void write_report(const std::filesystem::path& dir, const calibration::Dataset& data,
                  const calibration::CalibrationOutcome& outcome, const CalibrateCommandOptions& options) {
  std::filesystem::create_directories(dir);
  const calibration::MuscleCalibration& c = outcome.calibration;
  const calibration::CalibrationStats& s = c.stats;
  {
    std::ofstream csv(dir / "predictions.csv");
    csv << "# peha calibrate: per-row predictions of " << data.source << "\n";
    csv << "row,t_s,heldout,contraction,force_N,pressure_MPa,pressure_parametric_MPa,pressure_spgp_MPa,spgp_std_MPa\n";
    for (std::size_t i = 0; i < data.size(); ++i) {
      csv << fmt::format("{},{:.6g},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", i,
                         data.t_s.empty() ? static_cast<double>(i) : data.t_s[i], int(outcome.heldout[i]),
                         data.contraction[i], data.force_N[i], data.pressure_Pa[i] * 1e-6,
                         outcome.pressure_parametric_Pa[i] * 1e-6, outcome.pressure_spgp_Pa[i] * 1e-6,
                         outcome.spgp_std_Pa[i] * 1e-6);
    }
  }
  if (c.spgp) {
    // The SPGP's predictive band over (contraction, force): a grid 10 % beyond the data's ranges.
    std::ofstream grid(dir / "spgp_grid.csv");
    grid << "contraction,force_N,mean_MPa,std_MPa\n";
    const int n = 60;
    const double e_pad = 0.1 * (c.contraction.max - c.contraction.min), f_pad = 0.1 * (c.force_N.max - c.force_N.min);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const double x[2] = {c.contraction.min - e_pad + (c.contraction.max - c.contraction.min + 2 * e_pad) * i / (n - 1),
                             c.force_N.min - f_pad + (c.force_N.max - c.force_N.min + 2 * f_pad) * j / (n - 1)};
        grid << fmt::format("{:.9g},{:.9g},{:.9g},{:.9g}\n", x[0], x[1], c.spgp->predict_mean(x) * 1e-6,
                            std::sqrt(std::max(c.spgp->predict_variance(x), 0.0)) * 1e-6);
      }
    }
    std::ofstream pseudo(dir / "pseudo_inputs.csv");
    pseudo << "contraction,force_N\n";
    const Eigen::MatrixXd& z = c.spgp->pseudo_inputs();
    for (Eigen::Index m = 0; m < z.rows(); ++m) {
      pseudo << fmt::format("{:.9g},{:.9g}\n", c.spgp->input_mean()[0] + c.spgp->input_scale()[0] * z(m, 0),
                            c.spgp->input_mean()[1] + c.spgp->input_scale()[1] * z(m, 1));
    }
  }
  std::ofstream txt(dir / "summary.txt");
  const std::string summary = fmt::format(
      "muscle {} from {} (sha256 {})\n"
      "rows: {} train, {} held out ({})\n"
      "Tendon-spring (LM on the pressure error, best of {} restarts, {} converged, {:.1f} s):\n"
      "  a = {:.6g} N/MPa, b = {:.6g} N/MPa, c = {:.6g} N/MPa, k = {:.6g} N, eps0 = {:.6g}\n"
      "SPGP residual: {}\n"
      "pressure RMS error      train      held out\n"
      "  parametric          {:7.2f} kPa  {:7.2f} kPa\n"
      "  parametric + SPGP   {:7.2f} kPa  {:7.2f} kPa\n"
      "input ranges seen: contraction {:.4f}..{:.4f}, force {:.1f}..{:.1f} N, pressure {:.3f}..{:.3f} MPa\n",
      c.muscle, c.data_file, c.data_sha256, s.rows_train, s.rows_heldout, outcome.split,
      s.restarts, s.restarts_converged, s.lm_seconds, c.params.a_N_per_Pa * 1e6, c.params.b_N_per_Pa * 1e6,
      c.params.c_N_per_Pa * 1e6, c.params.k_N, c.params.eps0,
      c.spgp ? fmt::format("M = {} pseudo-inputs, {} iterations, {:.1f} s, NLML {:.2f}", c.spgp->num_pseudo(),
                           c.spgp->iterations(), s.spgp_seconds, c.spgp->final_nlml())
             : std::string("off"),
      s.train_rms_parametric_Pa * 1e-3, s.heldout_rms_parametric_Pa * 1e-3, s.train_rms_spgp_Pa * 1e-3,
      s.heldout_rms_spgp_Pa * 1e-3, c.contraction.min, c.contraction.max, c.force_N.min, c.force_N.max,
      c.pressure_Pa.min * 1e-6, c.pressure_Pa.max * 1e-6);
  txt << summary;
  fmt::print("\n{}", summary);
  if (options.plot) plot_with("plot_calibration.py", dir);
}

}  // namespace

int calibrate(const CalibrateCommandOptions& options) {
  return with_exit_codes([&] {
    calibration::DatasetRules rules;
    rules.min_rows = options.min_rows;
    const calibration::Dataset data = calibration::read_dataset(options.data, rules);
    calibration::CalibrateOptions o;
    o.muscle = options.muscle.empty() ? options.data.stem().string() : options.muscle;
    o.fit.restarts = options.restarts;
    o.fit.threads = options.threads;
    o.fit.seed = options.seed;
    o.spgp.num_pseudo = options.pseudo_inputs;
    o.spgp.max_iterations = options.spgp_iterations;
    o.spgp.seed = options.seed;
    o.use_spgp = options.use_spgp;
    if (!options.holdout) o.heldout_blocks.clear();
    fmt::print("peha calibrate: {} ({} rows, sha256 {}...)\n", options.data.string(), data.size(), data.sha256.substr(0, 12));
    ProgressPrinter lm("LM restarts"), gp("SPGP training");
    calibration::CalibrateProgress progress;
    progress.restarts = [&](int done, int total) { lm.update(done, total, fmt::format("{}/{}", done, total)); };
    progress.spgp = [&](int iteration, double nlml) {
      gp.update(iteration, options.spgp_iterations, fmt::format("NLML {:.1f}", nlml));
    };
    const calibration::CalibrationOutcome outcome = calibration::calibrate(data, o, progress);
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    calibration::write_calibration(options.out, outcome.calibration);
    std::filesystem::path report = options.report_dir;
    if (report.empty()) report = std::filesystem::path(options.out).replace_extension().string() + "_report";
    write_report(report, data, outcome, options);
    fmt::print("written: {} and {}/\n", options.out.string(), report.string());
    return 0;
  });
}

int check_config(const std::filesystem::path& config) {
  try {
    const config::Document doc = config::Document::load_file(config);
    config::Map root = doc.root();
    std::optional<mfb::LinkConfig> link;
    std::vector<std::string> joints;
    if (root.has("experiment") && root.string("experiment") == "right_arm") {
      const experiments::ArmScenario s = experiments::read_arm_scenario(doc);
      fmt::print("{}: OK\n  experiment right_arm: {}\n  {} actuated joints, {} postures (E3), {} goniometer movement(s) (E4), "
                 "{} bandwidth frequencies (E6), control at {} Hz\n",
                 config.string(), s.description, s.controller.joints.size(), s.postures.size(), s.goniometer.movements.size(),
                 s.bandwidth.frequencies_Hz.size(), 1.0 / s.period_s);
      link = s.link;
      joints = experiments::arm_joint_names(s);
    } else {
      const experiments::E1Scenario s = experiments::read_e1(doc);
      sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
      fmt::print("{}: OK\n  experiment gravity_compensation_1dof: {}\n  {} case(s), {} s at {} Hz, {} finger push(es), "
                 "plant model {}\n",
                 config.string(), s.description, s.cases.size(), s.duration_s, 1.0 / s.period_s, s.plant.finger.pushes.size(),
                 s.plant.model_file.string());
      link = s.link;
      joints = sim::one_dof_rig_joint_names();
    }
    if (link) {  // the board's channel map must load for the backend's joints
      const mfb::ChannelMap map = mfb::read_channel_map(config::Document::load_file(link->channel_map), joints);
      fmt::print("  mfb: channel map {} ({} joints), watchdogs board {} ms / host {} ms\n", link->channel_map.string(), map.joint_count(),
                 link->board_watchdog_s * 1e3, link->host_watchdog_s * 1e3);
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  }
}

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop = true; }
}  // namespace

mfb::EmulatorParams emulator_params(const EmulatorOptions& options, double period_s, const mfb::LinkConfig& link) {
  mfb::EmulatorParams p;
  p.bind = {io::parse_ipv4(options.bind), static_cast<std::uint16_t>(options.port)};
  p.period_s = period_s;
  p.watchdog_s = options.watchdog_ms ? *options.watchdog_ms * 1e-3 : link.board_watchdog_s;
  p.vent_s = link.vent_s;
  p.max_runtime_s = options.max_runtime_s;
  p.sessions = options.sessions;
  p.faults = {options.loss, options.duplicate, options.reorder, options.corrupt, options.delay_ms * 1e-3, options.fault_seed,
              options.estop_at_s, options.estop_for_s};
  return p;
}

int serve(mfb::BoardEmulator& board, const mfb::EmulatorParams& p, const EmulatorOptions& options, const std::string& what) {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  runtime::RealtimeOptions rt;
  rt.fifo_priority = options.fifo_priority;
  rt.lock_memory = options.fifo_priority > 0;
  const runtime::RealtimeReport report = runtime::configure_realtime_thread(rt);
  (void)report;  // its warnings were printed; the board runs best-effort without
  fmt::print("peha mfb-emulator: listening on udp://{} - {}, watchdog {} ms, vent {} s{}\n", board.local().to_string(), what,
             p.watchdog_s * 1e3, p.vent_s,
             p.faults.any() ? fmt::format("; injecting loss {} duplicate {} reorder {} corrupt {} delay {} ms{}", p.faults.loss,
                                          p.faults.duplicate, p.faults.reorder, p.faults.corrupt, options.delay_ms,
                                          p.faults.estop_from_s >= 0
                                              ? fmt::format(", e-stop at {} s for {} s", p.faults.estop_from_s, p.faults.estop_for_s)
                                              : std::string())
                            : std::string());
  std::fflush(stdout);
  board.run(g_stop);
  fmt::print("peha mfb-emulator: stopped\n{}\n", board.stats().table());
  return 0;
}

int mfb_emulator_arm(const EmulatorOptions& options, const config::Document& doc) {
  experiments::ArmScenario scenario = experiments::read_arm_scenario(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  if (!scenario.link) {
    fmt::print(stderr, "config error: {}: no mfb: section (channel map, watchdogs): see docs/runtime.md\n", doc.name());
    return 2;
  }
  const mfb::EmulatorParams p = emulator_params(options, scenario.period_s, *scenario.link);
  const mfb::ChannelMap map =
      mfb::read_channel_map(config::Document::load_file(scenario.link->channel_map), experiments::arm_joint_names(scenario));
  if (options.case_name.empty() || options.case_name == "postures") {
    const sim::RightArmPlantParams plant = experiments::postures_plant_params(scenario);
    mfb::BoardEmulator board(p, map, [plant] { return std::make_unique<sim::RightArmBackend>(plant); });
    return serve(board, p, options, fmt::format("right arm with the operator's E3 script ({} postures)", scenario.postures.size()));
  }
  // E4: the arm where the person starts, and the person's goniometer on its AD channel.
  const auto& g = scenario.goniometer;
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    if (options.case_name != "goniometer_" + g.movements[i].name) continue;
    if (!map.has_goniometer(1)) {
      fmt::print(stderr, "config error: {}: no R_EFE.goniometer channel to put the person's elbow on\n",
                 scenario.link->channel_map.string());
      return 2;
    }
    const experiments::GoniometerTrace trace = experiments::synthesize_goniometer(g, g.movements[i], scenario.seed + i);
    const sim::RightArmPlantParams plant = experiments::goniometer_plant_params(scenario, trace);
    mfb::BoardEmulator board(p, map, [plant] { return std::make_unique<sim::RightArmBackend>(plant); });
    const mfb::AnalogChannel channel = map.joint(1).goniometer;
    board.set_input_hook([&scenario, trace, channel](double t_s, mfb::BoardInputs& in) {
      bool clamped = false;
      in.ad[static_cast<std::size_t>(channel.channel)] = channel.to_code(experiments::goniometer_reading(scenario, trace, t_s), clamped);
    });
    return serve(board, p, options, fmt::format("right arm, E4: a person's elbow '{}' on the goniometer channel", trace.name));
  }
  std::string cases = "postures";
  for (const auto& m : g.movements) cases += ", goniometer_" + m.name;
  fmt::print(stderr, "error: the right arm's board serves --case {}; found '{}'\n", cases, options.case_name);
  return 2;
}

int mfb_emulator(const EmulatorOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    config::Map root = doc.root();
    if (root.has("experiment") && root.string("experiment") == "right_arm") return mfb_emulator_arm(options, doc);
    experiments::E1Scenario scenario = experiments::read_e1(doc);
    if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
    if (!scenario.link) {
      fmt::print(stderr, "config error: {}: no mfb: section (channel map, watchdogs): see docs/runtime.md\n", doc.name());
      return 2;
    }
    if (options.case_name.empty() && scenario.cases.size() > 1) {
      fmt::print(stderr, "error: {} has {} cases: give --case NAME (the payload the simulated rig carries; the host's "
                         "peha run --backend needs the same --case)\n", doc.name(), scenario.cases.size());
      return 2;
    }
    const experiments::E1Case* chosen = &scenario.cases.front();
    for (const auto& c : scenario.cases) {
      if (c.name == options.case_name) chosen = &c;
    }
    if (!options.case_name.empty() && chosen->name != options.case_name) {
      fmt::print(stderr, "error: no case named '{}' in {}\n", options.case_name, doc.name());
      return 2;
    }
    const mfb::EmulatorParams p = emulator_params(options, scenario.period_s, *scenario.link);
    const std::vector<std::string>& joints = sim::one_dof_rig_joint_names();
    const sim::OneDofRigParams plant = experiments::e1_plant_params(scenario, *chosen);
    mfb::BoardEmulator board(p, mfb::read_channel_map(config::Document::load_file(scenario.link->channel_map), joints),
                             [plant] { return std::make_unique<sim::OneDofRigBackend>(plant); });
    return serve(board, p, options, fmt::format("one-DOF rig, case {} ({} kg)", chosen->name, chosen->payload_kg));
  });
}

}  // namespace peha::app
