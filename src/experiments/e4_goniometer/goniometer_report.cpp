#include "peha/experiments/e4_goniometer/goniometer_report.hpp"

#include "peha/control/butterworth.hpp"
#include "peha/sim/plant_faults.hpp"
#include "peha/experiments/arm/arm_contract.hpp"
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

/// summary.csv's header and the rows of one in-process result.
constexpr const char* kSummaryHeader =
    "movement,variant,joint,range_deg,rms_error_deg,max_error_deg,delay_ms,rms_error_aligned_deg,peak_torque_cmd_Nm,"
    "joint_min_wire_tension_N,joint_min_wire_tension_limit_N,held_excursion_deg,peak_muscle_force_N,min_wire_tension_N,"
    "min_wire_tension_limit_N,peak_motor_Nm,max_tracking_rms_deg,max_tracking_error_deg,command_hf_rms_Nm,command_delay_ms,within_limits\n";

std::string summary_rows(const ArmScenario& scenario, const GoniometerResult& r) {
  double tension_limit = 0;
  for (const auto& c : r.verdict.checks) {
    if (c.figure.ends_with("lowest wire tension")) tension_limit = std::max(tension_limit, c.limit);
  }
  std::string rows;
  for (const GoniometerJointResult& j : r.joints) {
    const safety::Check* own = r.verdict.find(j.joint + " lowest wire tension");
    rows += fmt::format("{},{},{},{:.2f},{:.4f},{:.4f},{:.1f},{:.4f},{:.4f},{:.2f},{:.2f},{:.4f},{:.1f},{:.2f},{:.2f},{:.3f},{:.3g},{:.3g},{:.4f},{:.1f},{}\n",
                        r.name, to_string(r.variant), j.joint, j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3,
                        j.rms_error_aligned_deg, j.peak_torque_command_Nm, j.min_wire_tension_N, own ? own->limit : 0.0,
                        j.held_excursion_deg, r.peak_muscle_force_N, r.min_wire_tension_N, tension_limit, r.peak_motor_torque_Nm,
                        scenario.verdict.max_tracking_rms_deg, scenario.verdict.max_tracking_error_deg, j.command_hf_rms_Nm,
                        j.command_delay_s * 1e3, r.within_limits ? 1 : 0);
  }
  return rows;
}

/// The board run's table (person = the goniometer's reading, exo = the joint's encoder).
void print_board_table(const std::vector<GoniometerRealtimeResult>& results) {
  fmt::print("\n{:<10} {:<7} {:>9} {:>10} {:>10} {:>9} {:>12}   (person = the goniometer's reading, exo = the joint's encoder)\n",
             "variant", "joint", "range", "RMS error", "max error", "delay", "RMS aligned");
  for (const auto& rr : results) {
    const auto& r = rr.goniometer;
    for (const GoniometerJointResult& j : r.joints) {
      fmt::print("{:<10} {:<7} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg\n", to_string(r.variant), j.joint,
                 j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3, j.rms_error_aligned_deg);
    }
    fmt::print("{:<10} verdict {}, faults {}\n{}", to_string(r.variant), r.within_limits ? "OK" : "VIOLATED", rr.faults, r.verdict.failures());
  }
}

/// E4: each movement of the person (or one recording) with both variants, in process or on the board.
class GoniometerJob final : public ExperimentRun {
 public:
  GoniometerJob(const config::Document& doc, const RunRequest& request)
      : scenario_(arm_scenario_for_run(doc, request, "E4 (goniometer)", true)),
        doc_name_(doc.name()),
        log_columns_(goniometer_log_columns(scenario_)) {
    const auto& g = scenario_.goniometer;
    if (g.movements.empty()) {
      throw RequestError(fmt::format("{} has no goniometer: section (E4's sensor, filter and movements; docs/right-arm.md)", doc.name()));
    }
    if (!request.goniometer_csv.empty()) {
      double lo = -std::numbers::pi, hi = std::numbers::pi;
      for (const int j : g.joints) {
        lo = std::max(lo, scenario_.limits.joints[static_cast<std::size_t>(j)].min_angle_rad);
        hi = std::min(hi, scenario_.limits.joints[static_cast<std::size_t>(j)].max_angle_rad);
      }
      recording_.assign(g.joints.size(), read_goniometer_csv(request.goniometer_csv, g.sample_rate_Hz, lo, hi));
    }
    // Injected plant faults (in process), timed within the longest of the runs.
    double longest_s = 0;
    if (!recording_.empty()) longest_s = goniometer_run_duration_s(scenario_, recording_.front());
    for (std::size_t i = 0; i < g.movements.size() && recording_.empty(); ++i) {
      longest_s = std::max(longest_s, goniometer_run_duration_s(scenario_, synthesize_goniometers(g, g.movements[i], scenario_.seed + i).front()));
    }
    for (const std::string& spec : request.faults) {
      try {
        scenario_.faults.push_back(sim::parse_fault_spec(spec, arm_joint_names(scenario_), longest_s));
      } catch (const std::invalid_argument& e) {
        throw RequestError(e.what());
      }
    }
  }

  std::uint64_t seed() const override { return scenario_.seed; }
  TelemetrySource telemetry_source() const override { return {log_columns_, scenario_.telemetry}; }
  const mfb::LinkConfig* link() const override { return scenario_.link ? &*scenario_.link : nullptr; }
  /// The synthetic person's movements; a recording is one run.
  std::vector<std::string> case_names() const override {
    std::vector<std::string> names;
    if (recording_.empty()) {
      for (const auto& m : scenario_.goniometer.movements) names.push_back(m.name);
    }
    return names;
  }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>& cases) const override {
    const auto& g = scenario_.goniometer;
    fmt::print("peha run: {} --experiment goniometer (E4), output {}\n  goniometer {:.0f} Hz, noise {:.2f} deg, Butterworth order {} at "
               "{:.1f} Hz (group delay {:.1f} ms) on {}; held (inverse dynamics + hold impedance): {}\n  {}; open-loop and feedback each\n",
               doc_name_, ctx.shown_dir().string(), g.sample_rate_Hz, models::rad_to_deg(g.noise_rad), g.filter_order, g.cutoff_Hz,
               control::group_delay_s(control::design_butterworth_lowpass(g.filter_order, g.cutoff_Hz, g.sample_rate_Hz), 0.0) * 1e3,
               driven_names(scenario_), held_posture(scenario_),
               recording_.empty() ? fmt::format("synthetic person: {} movement(s)", cases.size())
                                  : "recording: " + ctx.request.goniometer_csv.string() + (g.joints.size() > 1 ? " (on every driven joint)" : ""));
  }

  void run_case(std::size_t i, const RunContext& ctx) override {
    if (ctx.realtime) {
      for (const auto variant : kVariants) {
        board_results_.push_back(run_goniometer_realtime(scenario_, i, variant, *ctx.realtime));
        print_realtime(board_results_.back(), ctx.dir / fmt::format("timing_{}", to_string(variant)));
      }
      return;
    }
    const auto& g = scenario_.goniometer;
    const std::vector<GoniometerTrace> traces = recording_.empty() ? synthesize_goniometers(g, g.movements[i], scenario_.seed + i) : recording_;
    const GoniometerTrace& trace = traces.front();
    const double duration_s = goniometer_run_duration_s(scenario_, trace);
    fmt::print("{:.1f} s simulated, open-loop and feedback\n", duration_s);
    std::fflush(stdout);
    runtime::CsvLog log(log_columns_, static_cast<std::size_t>(duration_s / scenario_.period_s) + 2);
    const bool replay = ctx.backend.kind == hardware::BackendKind::kReplay;
    for (const auto variant : kVariants) {
      log.clear();
      // Both variants on a replayed log too: the one that recorded it gives its commands back.
      const hardware::Hardware hw = hardware::open_backend(ctx.backend, goniometer_hardware(scenario_, goniometer_plant_params(scenario_, traces)));
      runtime::TelemetryTee tee(log, ctx.telemetry, log_columns_);
      results_.push_back(run_goniometer(scenario_, traces, variant, hw, &tee));
      log.write(ctx.dir / fmt::format("e4_{}_{}.csv", trace.name, to_string(variant)),
                {fmt::format("case: E4 goniometer-driven {}, movement {}, variant {}", driven_names(scenario_), trace.name, to_string(variant)),
                 fmt::format("config: {}; seed {}", ctx.request.config.string(), scenario_.seed),
                 replay ? "replayed from " + ctx.backend.replay_log.string() + ": sensors and goniometers are the log's, person_* the goniometer, plant_* NaN"
                        : "person_* is the person's true joint; plant_* columns are simulator truth the controller never sees"});
      finish_telemetry(tee);
      if (hw.replay) print_replay(*hw.replay, ctx.dir / fmt::format("replay_{}_{}.csv", trace.name, to_string(variant)));
    }
    if (recording_.empty() && !replay) {
      for (std::size_t k = 0; k < traces.size(); ++k) {
        // One recording per goniometer; the first keeps the single-joint name.
        const std::string suffix = k == 0 ? "" : "_" + arm_log_prefix(scenario_, static_cast<std::size_t>(g.joints[k]));
        write_goniometer_csv(ctx.dir / fmt::format("goniometer_{}{}.csv", trace.name, suffix), traces[k]);
      }
    }
  }

  Conclusion conclude(const RunContext& ctx) override {
    // The paper's open-loop replay shows what the feedback adds: a comparison, not judged.
    Conclusion c{0, "e4_<movement>_<variant>.csv, summary.csv, config.yaml", "plot_goniometer.py", {}, 0,
                 "the open-loop variant (the goniometer's angle replayed without feedback)"};
    auto add = [&c](GoniometerVariant v, std::size_t failed) {
      (v == GoniometerVariant::kOpenLoop ? c.comparison_failures : c.failed_figures) += failed;
    };
    if (ctx.realtime) {
      print_board_table(board_results_);
      for (const auto& rr : board_results_) add(rr.goniometer.variant, failed_figures(rr.goniometer.verdict) + (rr.faults > 0 && rr.goniometer.within_limits));
      c.written = "e4_<movement>_<variant>.csv, timing_<variant>/, config.yaml";
      c.plot_tool.clear();
      return c;
    }
    std::ofstream summary(ctx.dir / "summary.csv");
    summary << kSummaryHeader;
    for (const GoniometerResult& r : results_) summary << summary_rows(scenario_, r);
    summary.close();  // the plotter reads it next
    print_goniometer_tables(results_);
    for (const GoniometerResult& r : results_) add(r.variant, failed_figures(r.verdict));
    if (recording_.empty() && ctx.backend.kind != hardware::BackendKind::kReplay) {
      c.written += ", goniometer_<movement>.csv (replayable with --goniometer-csv)";
    }
    return c;
  }

 private:
  ArmScenario scenario_;
  std::string doc_name_;
  std::vector<std::string> log_columns_;  ///< of e4_<movement>_<variant>.csv
  std::vector<GoniometerTrace> recording_;  ///< --goniometer-csv on every driven joint (empty: synthetic movements)
  std::vector<GoniometerResult> results_;
  std::vector<GoniometerRealtimeResult> board_results_;
};

}  // namespace

bool print_goniometer_tables(const std::vector<GoniometerResult>& results) {
  fmt::print("\n{:<10} {:<10} {:<7} {:>9} {:>10} {:>10} {:>9} {:>12} {:>11} {:>11} {:>11} {:>10} {:>10} {:>7}\n", "movement", "variant", "joint",
             "range", "RMS error", "max error", "delay", "RMS aligned", "peak tau", "min wire", "held moved", "tau HF", "tau delay", "RTF");
  for (const auto& r : results) {
    for (const GoniometerJointResult& j : r.joints) {
      fmt::print("{:<10} {:<10} {:<7} {:>5.1f} deg {:>6.2f} deg {:>6.2f} deg {:>6.0f} ms {:>8.2f} deg {:>7.2f} Nm {:>9.1f} N {:>7.2f} deg "
                 "{:>6.3f} Nm {:>7.0f} ms {:>7.1f}\n",
                 r.name, to_string(r.variant), j.joint, j.range_deg, j.rms_error_deg, j.max_error_deg, j.delay_s * 1e3,
                 j.rms_error_aligned_deg, j.peak_torque_command_Nm, j.min_wire_tension_N, j.held_excursion_deg, j.command_hf_rms_Nm,
                 j.command_delay_s * 1e3, r.realtime_factor);
    }
    for (const GoniometerJointFigure& p : r.passive) fmt::print("{:<10} {:<10} {:<7} passive, peak speed {:.0f} deg/s\n", r.name, to_string(r.variant), p.joint, p.value);
  }
  bool safe = true;
  for (const auto& r : results) {
    safe = safe && r.within_limits;
    fmt::print("verdict ({}, {}): {}\n{}", r.name, to_string(r.variant), r.within_limits ? "OK" : "VIOLATED",
               r.verdict.describe_all());
  }
  return safe;
}

std::unique_ptr<ExperimentRun> make_goniometer_run(const config::Document& doc, const RunRequest& request) {
  return std::make_unique<GoniometerJob>(doc, request);
}

}  // namespace peha::experiments
