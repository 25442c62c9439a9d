#include "peha/experiments/creep/creep_contract.hpp"

#include "peha/experiments/creep/creep.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>

namespace peha::experiments {
namespace {

void write_series(const std::filesystem::path& path, const CreepRun& r) {
  std::ofstream out(path);
  out << "t_s,angle_deg,truth_agonist_mm,truth_antagonist_mm,estimate_agonist_mm,estimate_antagonist_mm,sigma_agonist_mm,"
         "sigma_antagonist_mm,tracking_rms_agonist_N,tracking_rms_antagonist_N,gated_agonist,gated_antagonist,alerts\n";
  for (const CreepSample& s : r.samples) {
    out << fmt::format("{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.2f},{:.2f},{:.3f},{:.3f},{}\n", s.t_s, s.angle_deg,
                       s.truth_m[0] * 1e3, s.truth_m[1] * 1e3, s.estimate_m[0] * 1e3, s.estimate_m[1] * 1e3, s.sigma_m[0] * 1e3,
                       s.sigma_m[1] * 1e3, s.tracking_rms_N[0], s.tracking_rms_N[1], s.gated_fraction[0], s.gated_fraction[1],
                       s.alerts);
  }
}

void write_releases(const std::filesystem::path& path, const CreepRun& r) {
  std::ofstream out(path);
  out << "release_time_s,angle_deg,static_torque_error_pct\n";
  for (const CreepRelease& rel : r.releases) out << fmt::format("{:.3f},{:.3f},{:.3f}\n", rel.time_s, rel.angle_deg, rel.static_torque_error_pct);
}

void write_summary(const std::filesystem::path& path, const std::vector<CreepRun>& runs) {
  std::ofstream out(path);
  out << "run,variant,force_trim_rate_1ps,estimator,estimate_rms_agonist_mm,estimate_rms_antagonist_mm,estimate_max_agonist_mm,"
         "estimate_max_antagonist_mm,final_truth_agonist_mm,final_truth_antagonist_mm,truth_cross_agonist_s,truth_cross_antagonist_s,"
         "alert_creep_agonist_s,alert_creep_antagonist_s,alert_slack_agonist_s,alert_slack_antagonist_s,"
         "tracking_rms_last_quarter_agonist_N,tracking_rms_last_quarter_antagonist_N,static_error_last_quarter_max_pct,"
         "static_error_last_quarter_mean_pct,min_wire_tension_N,realtime_factor\n";
  for (const CreepRun& r : runs) {
    out << fmt::format("{},{},{:g},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.1f},{:.2f},{:.2f},{:.3f},"
                       "{:.3f},{:.2f},{:.1f}\n",
                       r.name, r.variant, r.force_trim_rate_1ps, r.estimator ? 1 : 0, r.estimate_rms_m[0] * 1e3,
                       r.estimate_rms_m[1] * 1e3, r.estimate_max_m[0] * 1e3, r.estimate_max_m[1] * 1e3, r.final_truth_m[0] * 1e3,
                       r.final_truth_m[1] * 1e3, r.truth_cross_s[0], r.truth_cross_s[1], r.alert_time_s[0], r.alert_time_s[1],
                       r.alert_time_s[2], r.alert_time_s[3], r.tracking_rms_last_quarter_N[0], r.tracking_rms_last_quarter_N[1],
                       r.static_error_last_quarter_max_pct, r.static_error_last_quarter_mean_pct, r.min_wire_tension_N,
                       r.realtime_factor);
  }
}

std::string alert_text(double t_s) { return t_s >= 0 ? fmt::format("{:.0f} s", t_s) : std::string("-"); }

class CreepJob final : public ExperimentRun {
 public:
  CreepJob(const config::Document& doc, const RunRequest& request) : scenario_(read_creep(doc)) {
    if (request.seed) scenario_.e1.plant.seed = scenario_.e1.seed = *request.seed;
    if (request.force_trim_rate_1ps) scenario_.creep.force_trim_rates_1ps = {*request.force_trim_rate_1ps};
  }

  std::uint64_t seed() const override { return scenario_.e1.seed; }
  const mfb::LinkConfig* link() const override { return nullptr; }  // in process only
  std::vector<std::string> case_names() const override {
    std::vector<std::string> names;
    for (const auto& c : scenario_.e1.cases) names.push_back(c.name);
    return names;
  }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>& cases) const override {
    const auto& cable = scenario_.e1.plant.joint.agonist.cable;
    fmt::print("peha run: {}\n  {}\n  {} case(s), {:.0f} s simulated per run, plant creep {:g} m/(N s) up to {:g} mm, seed {}, output {}\n",
               ctx.request.config.string(), scenario_.e1.description, cases.size(), scenario_.e1.duration_s, cable.creep_m_per_N_s,
               cable.max_creep_m * 1e3, scenario_.e1.seed, ctx.shown_dir().string());
  }

  /// Every plant variant x force-trim rate x estimator off/on on case `i`.
  void run_case(std::size_t i, const RunContext& ctx) override {
    const E1Case& chosen = scenario_.e1.cases[i];
    fmt::print("\n");
    for (const PlantVariant& v : scenario_.creep.variants) {
      std::optional<control::OneDofControllerModel> calibrated;
      for (double trim : scenario_.creep.force_trim_rates_1ps) {
        if (scenario_.creep.calibrate && !calibrated) {
          fmt::print("    {}: recording and calibrating both muscles on the plant (its wires not yet crept) ... ", v.name);
          std::fflush(stdout);
          const auto start = std::chrono::steady_clock::now();
          calibrated = creep_calibrated_scenario(scenario_, v).controller;
          fmt::print("{:.0f} s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        const control::OneDofControllerModel* model = calibrated ? &*calibrated : nullptr;
        for (bool on : {false, true}) {
          fmt::print("    {} trim {:g}/s{} estimator {} ... ", v.name, trim, model ? " (calibrated)" : "", on ? "on " : "off");
          std::fflush(stdout);
          runs_.push_back(run_creep_case(scenario_, chosen, v, trim, on, model));
          const CreepRun& r = runs_.back();
          write_series(ctx.dir / fmt::format("creep_{}.csv", r.name), r);
          write_releases(ctx.dir / fmt::format("releases_{}.csv", r.name), r);
          fmt::print("{:.0f} s at {:.0f}x real time\n", r.simulated_s, r.realtime_factor);
        }
      }
    }
  }

  Conclusion conclude(const RunContext& ctx) override {
    write_summary(ctx.dir / "summary.csv", runs_);
    print_table();
    const safety::Verdict verdict = creep_verdict(scenario_, runs_);
    fmt::print("\nverdict (creep.verdict: section; plant variants other than {} are reported, not judged):\n{}",
               scenario_.creep.variants.front().name, verdict.describe_all());
    return {failed_figures(verdict), "summary.csv, creep_<run>.csv, releases_<run>.csv, config.yaml", "plot_creep.py", {}, 0, {}};
  }

 private:
  void print_table() const {
    fmt::print("\n{:<34} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8}\n", "run", "truth_ag", "truth_an",
               "rms_ag", "max_ag", "rms_an", "max_an", "cross_ag", "alert_ag", "trk_ag/N", "trk_an/N", "tau_max%", "tau_avg%");
    for (const CreepRun& r : runs_) {
      fmt::print("{:<34} {:>7.2f}mm {:>7.2f}mm {:>7.3f}mm {:>7.3f}mm {:>6.3f}mm {:>6.3f}mm {:>9} {:>9} {:>9.1f} {:>9.1f} {:>8.2f} {:>8.2f}\n",
                 r.name, r.final_truth_m[0] * 1e3, r.final_truth_m[1] * 1e3, r.estimate_rms_m[0] * 1e3, r.estimate_max_m[0] * 1e3,
                 r.estimate_rms_m[1] * 1e3, r.estimate_max_m[1] * 1e3, alert_text(r.truth_cross_s[0]), alert_text(r.alert_time_s[0]),
                 r.tracking_rms_last_quarter_N[0], r.tracking_rms_last_quarter_N[1], r.static_error_last_quarter_max_pct,
                 r.static_error_last_quarter_mean_pct);
      if (r.faults) fmt::print("{:<34} SUPERVISOR FAULT: {}\n", "", r.fault_reason);
      for (int b = 0; b < 4; ++b) {
        if (r.alert_time_s[b] >= 0) {
          fmt::print("{:<34} ALERT {} at {:.1f} s\n", "", control::creep_alert_name(static_cast<control::CreepAlert>(1u << b)),
                     r.alert_time_s[b]);
        }
      }
    }
  }

  CreepScenario scenario_;
  std::vector<CreepRun> runs_;
};

ScenarioCheck check_creep(const std::filesystem::path& config, const config::Document& doc) {
  const CreepScenario s = read_creep(doc);
  sim::load_mjcf(s.e1.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}\n  experiment wire_creep: {}\n  {} s at {} Hz, {} finger push(es), {} plant variant(s) x {} trim rate(s) x "
             "estimator off/on, plant model {}\n",
             config.string(), s.e1.description, s.e1.duration_s, 1.0 / s.e1.period_s, s.e1.plant.finger.pushes.size(),
             s.creep.variants.size(), s.creep.force_trim_rates_1ps.size(), s.e1.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.e1.link, s.e1.lifecycle,
          {joint_envelope(sim::one_dof_rig_joint_names()[0], s.e1.controller.joint, s.e1.limits.joints[0])}};
}

std::optional<BoardPlant> creep_board(const config::Document& doc, const EmulatorCase&) {
  fmt::print(stderr, "error: {}: the wire-creep experiment runs in-process only (it judges the estimate against the plant's "
                     "true creep); serve its E1 scenario instead\n", doc.name());
  return std::nullopt;
}

}  // namespace

Experiment creep_experiment() {
  Takes takes;
  takes.cases = takes.force_trim = true;
  takes.why_not_hardware = "the creep experiment judges the estimate against the plant's true creep: in-process only";
  return {"wire_creep", "one-DOF rig", "wire creep and slack: the creep estimator off and on over a long E1-like run (configs/e1_creep.yaml)",
          {{"", "wire creep estimator", takes,
            [](const config::Document& doc, const RunRequest& request) { return std::make_unique<CreepJob>(doc, request); }}},
          check_creep, creep_board};
}

}  // namespace peha::experiments
