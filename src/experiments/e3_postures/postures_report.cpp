#include "peha/experiments/e3_postures/postures_report.hpp"

#include "peha/experiments/arm/arm_contract.hpp"
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

class PosturesJob final : public ExperimentRun {
 public:
  PosturesJob(const config::Document& doc, const RunRequest& request)
      : scenario_(arm_scenario_for_run(doc, request, "E3 (postures)", true)), doc_name_(doc.name()), log_columns_(arm_log_columns(scenario_)) {
    for (const std::string& spec : request.faults) {
      try {
        scenario_.faults.push_back(sim::parse_fault_spec(spec, arm_joint_names(scenario_), postures_duration_s(scenario_)));
      } catch (const std::invalid_argument& e) {
        throw RequestError(e.what());
      }
    }
  }

  std::uint64_t seed() const override { return scenario_.seed; }
  TelemetrySource telemetry_source() const override { return {log_columns_, scenario_.telemetry}; }
  const mfb::LinkConfig* link() const override { return scenario_.link ? &*scenario_.link : nullptr; }
  std::vector<std::string> case_names() const override { return {}; }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>&) const override {
    fmt::print("peha run: {} --experiment postures (E3)\n  {}\n  {} postures, {:.0f} s simulated, seed {}, output {}\n", doc_name_,
               scenario_.description, scenario_.postures.size(), postures_duration_s(scenario_), scenario_.seed, ctx.shown_dir().string());
    if (ctx.realtime && scenario_.link->boards.size() > 1) {
      const std::vector<io::UdpEndpoint> at = mfb::board_endpoints(*scenario_.link, ctx.realtime->backend.boards);
      fmt::print("  {} boards:", at.size());
      for (std::size_t b = 0; b < at.size(); ++b) {
        fmt::print(" {} at udp://{}{}", scenario_.link->boards[b].name, at[b].to_string(), b + 1 < at.size() ? "," : "\n");
      }
    }
  }

  void run_case(std::size_t, const RunContext& ctx) override {
    if (ctx.realtime) {
      realtime_ = run_postures_realtime(scenario_, *ctx.realtime);
      result_ = realtime_->postures;
      return;
    }
    // In process through the door: the simulated arm (sim:) or a recorded E3 log (replay:), whose
    // commands are written beside the recorded ones (replay_postures.csv).
    const hardware::Hardware hw = hardware::open_backend(ctx.backend, postures_hardware(scenario_));
    const double duration_s = postures_duration_s(scenario_);
    runtime::CsvLog log(log_columns_, static_cast<std::size_t>(duration_s / scenario_.period_s) + 2);
    std::vector<std::string> comments = {fmt::format("case: E3 postures, {}", scenario_.description),
                                         fmt::format("config: {}; seed {}", ctx.request.config.string(), scenario_.seed),
                                         "plant_* columns are simulator truth the controller never sees"};
    if (hw.replay) {
      comments.back() = "replayed from " + ctx.backend.replay_log.string() + ": the sensors are the log's, plant_* columns NaN";
    } else {
      for (const sim::PlantFault& f : scenario_.faults) fmt::print("  plant fault: {}\n", sim::describe(f, arm_joint_names(scenario_)));
    }
    runtime::TelemetryTee tee(log, ctx.telemetry, log_columns_);
    result_ = run_postures_on(scenario_, *hw.backend, dynamic_cast<sim::ArmBackend*>(hw.backend.get()), &tee);
    log.write(ctx.dir / "e3_postures.csv", comments);
    finish_telemetry(tee);
    if (hw.replay) print_replay(*hw.replay, ctx.dir / "replay_postures.csv");
  }

  Conclusion conclude(const RunContext& ctx) override {
    const PosturesResult& r = result_;
    if (r.faults) fmt::print("  SUPERVISOR FAULT: {}\n", r.fault_reason);
    write_postures_summary(ctx.dir / "summary.csv", r, scenario_.observe_s);  // closed: the plotter reads it next
    fmt::print("verdict (thresholds from the verdict: section):\n{}verdict: {}; peak operator torque {:.1f} Nm; real-time factor {:.1f}\n",
               r.verdict.describe_all(), r.within_limits ? "OK" : "VIOLATED", r.peak_operator_torque_Nm, r.realtime_factor);
    if (realtime_) print_realtime(*realtime_, ctx.dir / "timing");
    return {failed_figures(r.verdict), "e3_postures.csv, summary.csv, config.yaml", "plot_arm.py", {}, 0, {}};
  }

 private:
  ArmScenario scenario_;
  std::string doc_name_;
  std::vector<std::string> log_columns_;  ///< of e3_postures.csv
  PosturesResult result_;
  std::optional<PosturesRealtimeResult> realtime_;
};

}  // namespace

std::unique_ptr<ExperimentRun> make_postures_run(const config::Document& doc, const RunRequest& request) {
  return std::make_unique<PosturesJob>(doc, request);
}

}  // namespace peha::experiments
