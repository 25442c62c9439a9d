#include "peha/experiments/e5_max_force/e5_contract.hpp"

#include "peha/experiments/e5_max_force/max_force_realtime.hpp"
#include "peha/experiments/e5_max_force/max_force_report.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>

#include <cmath>

namespace peha::experiments {
namespace {

/// One case in process, on the simulated clamped rig or a replayed log (the door's sim: or replay:).
E5Result run_in_process(const E5Scenario& scenario, const E5Case& c, const RunContext& ctx) {
  const auto rows = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s)) + 1;
  runtime::CsvLog log(e5_log_columns(), rows);
  runtime::TelemetryTee tee(log, ctx.telemetry, e5_log_columns());
  const hardware::Hardware hw = hardware::open_backend(ctx.backend, e5_hardware(scenario, c));
  E5Result r = run_e5_on(scenario, c, *hw.backend, dynamic_cast<sim::OneDofRigBackend*>(hw.backend.get()), &tee);
  finish_in_process_case(ctx, hw, log, tee, "e5", c.name,
                         {fmt::format("case: {} (clamp at {} deg)", c.name, r.locked_angle_deg), fmt::format("config: {}", ctx.request.config.string()),
                          fmt::format("seed: {}", scenario.seed),
                          "pressures gauge; stop: 0 none, 1 force ceiling, 2 supply, 3 rate limit, 4 supervisor; "
                          "plant_* columns are simulator truth the controller never sees"},
                         r.simulated_s, r.realtime_factor);
  return r;
}

class E5Job final : public ExperimentRun {
 public:
  E5Job(const config::Document& doc, const RunRequest& request) : scenario_(read_e5(doc)) {
    if (request.seed) scenario_.plant.seed = scenario_.seed = *request.seed;
  }

  std::uint64_t seed() const override { return scenario_.seed; }
  TelemetrySource telemetry_source() const override { return {e5_log_columns(), scenario_.telemetry}; }
  const mfb::LinkConfig* link() const override { return scenario_.link ? &*scenario_.link : nullptr; }
  std::vector<std::string> case_names() const override {
    std::vector<std::string> names;
    for (const auto& c : scenario_.cases) names.push_back(c.name);
    return names;
  }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>& cases) const override {
    fmt::print("peha run: {}\n  {}\n  {} case(s), {} ramped at {} MPa/s from {} s, {:.1f} s each, seed {}, output {}\n",
               ctx.request.config.string(), scenario_.description, cases.size(), scenario_.ramp.muscle == 0 ? "agonist" : "antagonist",
               scenario_.ramp.rate_Pa_per_s * 1e-6, scenario_.ramp.start_s, scenario_.duration_s, scenario_.seed, ctx.shown_dir().string());
  }

  void run_case(std::size_t i, const RunContext& ctx) override {
    const E5Case& c = scenario_.cases[i];
    if (!ctx.realtime) {
      results_.push_back(run_in_process(scenario_, c, ctx));
      return;
    }
    const E5RealtimeResult rr = run_e5_realtime(scenario_, c, *ctx.realtime);
    results_.push_back(rr.e5);
    print_realtime(rr, ctx.dir / fmt::format("timing_{}", c.name));
  }

  Conclusion conclude(const RunContext& ctx) override {
    write_e5_summary(ctx.dir / "summary.csv", results_);
    print_e5_table(results_);
    Conclusion c{0, "summary.csv, config.yaml, e5_<case>.csv", "plot_max_force.py", {"--title", "E5 maximum-force ramp, one-DOF PEHA rig (clamped)"}, 0, {}};
    for (const E5Result& r : results_) c.failed_figures += failed_figures(r.verdict);
    return c;
  }

 private:
  E5Scenario scenario_;
  std::vector<E5Result> results_;
};

ScenarioCheck check_e5(const std::filesystem::path& config, const config::Document& doc) {
  const E5Scenario s = read_e5(doc);
  sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}\n  experiment max_force_ramp: {}\n  {} case(s), {} ramped at {} MPa/s, {} s at {} Hz, plant model {}\n",
             config.string(), s.description, s.cases.size(), s.ramp.muscle == 0 ? "agonist" : "antagonist", s.ramp.rate_Pa_per_s * 1e-6,
             s.duration_s, 1.0 / s.period_s, s.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.link, s.lifecycle, {joint_envelope(sim::one_dof_rig_joint_names()[0], s.joint, s.limits.joints[0])}};
}

std::optional<BoardPlant> e5_board(const config::Document& doc, const EmulatorCase& request) {
  E5Scenario scenario = read_e5(doc);
  if (request.seed) scenario.plant.seed = scenario.seed = *request.seed;
  if (!has_link(doc, scenario.link)) return std::nullopt;
  std::vector<std::string> names;
  for (const auto& c : scenario.cases) names.push_back(c.name);
  const std::optional<std::size_t> i = emulator_case(doc, names, request.case_name, "the clamp's angle", "");
  if (!i) return std::nullopt;
  const E5Case& c = scenario.cases[*i];
  return board_for(*scenario.link, scenario.period_s, e5_hardware(scenario, c),
                   fmt::format("one-DOF rig clamped, case {} ({} deg)", c.name, models::rad_to_deg(c.locked_angle_rad)));
}

}  // namespace

Experiment e5_experiment() {
  Takes takes;
  takes.cases = takes.boards = takes.replay = true;
  return {"max_force_ramp", "one-DOF rig", "E5: the maximum-force test, one muscle ramped against the clamped rig (configs/e5_max_force.yaml)",
          {{"", "E5 maximum force", takes,
            [](const config::Document& doc, const RunRequest& request) { return std::make_unique<E5Job>(doc, request); }}},
          check_e5, e5_board};
}

}  // namespace peha::experiments
