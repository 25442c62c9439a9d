#include "peha/experiments/e1_gravity/e1_contract.hpp"

#include "peha/experiments/e1_gravity/e1_realtime.hpp"
#include "peha/experiments/e1_gravity/e1_report.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>

namespace peha::experiments {
namespace {

/// One case with one model variant in process, on the simulated rig or a replayed log (the door's
/// sim: or replay:): its per-cycle log e1_<case>.csv; a replay also writes the commands beside the
/// recorded ones (replay_<case>.csv).
E1Result run_in_process(const E1Scenario& scenario, const E1Case& c, const RunContext& ctx) {
  const auto rows = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s)) + 1;
  runtime::CsvLog log(e1_log_columns(), rows);
  runtime::TelemetryTee tee(log, ctx.telemetry, e1_log_columns());
  const hardware::Hardware hw = hardware::open_backend(ctx.backend, e1_hardware(scenario, c));
  E1Result r = run_e1_on(scenario, c, *hw.backend, dynamic_cast<sim::OneDofRigBackend*>(hw.backend.get()), &tee);
  std::vector<std::string> comments = {fmt::format("case: {} ({} kg payload)", c.name, c.payload_kg),
                                       fmt::format("config: {}", ctx.request.config.string()), fmt::format("seed: {}", scenario.seed),
                                       "pressures gauge; plant_* columns are simulator truth the controller never sees"};
  if (hw.replay) {
    comments.back() = "pressures gauge; replayed from " + ctx.backend.replay_log.string() + ": the sensors are the log's, plant_* columns NaN";
  }
  finish_in_process_case(ctx, hw, log, tee, "e1", c.name, comments, r.simulated_s, r.realtime_factor);
  return r;
}

class E1Job final : public ExperimentRun {
 public:
  E1Job(const config::Document& doc, const RunRequest& request) : scenario_(read_e1(doc)) {
    if (request.seed) scenario_.plant.seed = scenario_.seed = *request.seed;
    if (request.force_trim_rate_1ps) scenario_.controller.allocation.force_trim_rate_1ps = *request.force_trim_rate_1ps;
    for (const std::string& spec : request.faults) {
      try {
        scenario_.plant.faults.push_back(sim::parse_fault_spec(spec, sim::one_dof_rig_joint_names(), scenario_.duration_s));
      } catch (const std::invalid_argument& e) {
        throw RequestError(e.what());
      }
    }
    variants_ = e1_variants(scenario_, request.calibration);
  }

  std::uint64_t seed() const override { return scenario_.seed; }
  TelemetrySource telemetry_source() const override { return {e1_log_columns(), scenario_.telemetry}; }
  const mfb::LinkConfig* link() const override { return scenario_.link ? &*scenario_.link : nullptr; }
  std::vector<std::string> case_names() const override {
    std::vector<std::string> names;
    for (const auto& c : scenario_.cases) names.push_back(c.name);
    return names;
  }

  void print_header(const RunContext& ctx, const std::vector<std::size_t>& cases) const override {
    const double trim = scenario_.controller.allocation.force_trim_rate_1ps;
    fmt::print("peha run: {}\n  {}\n  {} case(s) x {} model(s), {:.1f} s simulated each, seed {}, force trim {}, output {}\n",
               ctx.request.config.string(), scenario_.description, cases.size(), variants_.size(), scenario_.duration_s, scenario_.seed,
               trim > 0 ? fmt::format("{} /s", trim) : std::string("off"), ctx.shown_dir().string());
  }

  /// The case with every model variant (named <case>_<variant> when calibrated).
  void run_case(std::size_t i, const RunContext& ctx) override {
    for (const E1Variant& v : variants_) {
      E1Case c = scenario_.cases[i];
      if (!v.label.empty()) {
        c.name += "_" + v.label;
        fmt::print("\n      {} ... ", v.label);
        std::fflush(stdout);
      }
      if (!ctx.realtime) {
        results_.push_back(run_in_process(v.scenario, c, ctx));
        if (results_.back().faults) fmt::print("    SUPERVISOR FAULT: {}\n", results_.back().fault_reason);
        continue;
      }
      const E1RealtimeResult rr = run_e1_realtime(v.scenario, c, *ctx.realtime);
      results_.push_back(rr.e1);
      print_realtime(rr, ctx.dir / fmt::format("timing_{}", c.name));
    }
  }

  Conclusion conclude(const RunContext& ctx) override {
    write_e1_summary(ctx.dir / "summary.csv", results_);
    print_e1_table(results_);
    Conclusion c{0, "summary.csv, config.yaml, e1_<case>.csv", "plot_run.py", {"--title", "E1 gravity compensation, one-DOF PEHA rig"}, 0,
                 "the paper's parametric model alone (its SPGP residual is what makes it hold)"};
    // With an SPGP variant beside it, the parametric model alone is the comparison that shows why the
    // SPGP is needed; without one it is the model that runs, and judged.
    const bool compared = variants_.size() > 1;
    for (std::size_t i = 0; i < results_.size(); ++i) {
      const bool comparison = compared && variants_[i % variants_.size()].label == "parametric";
      (comparison ? c.comparison_failures : c.failed_figures) += failed_figures(results_[i].verdict);
    }
    return c;
  }

 private:
  E1Scenario scenario_;
  std::vector<E1Variant> variants_;
  std::vector<E1Result> results_;
};

ScenarioCheck check_e1(const std::filesystem::path& config, const config::Document& doc) {
  const E1Scenario s = read_e1(doc);
  sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}\n  experiment gravity_compensation_1dof: {}\n  {} case(s), {} s at {} Hz, {} finger push(es), "
             "plant model {}\n",
             config.string(), s.description, s.cases.size(), s.duration_s, 1.0 / s.period_s, s.plant.finger.pushes.size(),
             s.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.link, s.lifecycle,
          {joint_envelope(sim::one_dof_rig_joint_names()[0], s.controller.joint, s.limits.joints[0])}};
}

/// The emulator's rig: a payload case, or a calibration recording (the rig with the excitation's
/// payload, pinned where the operator pins it).
std::optional<BoardPlant> e1_board(const config::Document& doc, const EmulatorCase& request) {
  E1Scenario scenario = read_e1(doc);
  if (request.seed) scenario.plant.seed = scenario.seed = *request.seed;
  if (!has_link(doc, scenario.link)) return std::nullopt;
  if (const std::string outage = emulator_outage_error(scenario.plant.faults); !outage.empty()) {
    fmt::print(stderr, "config error: {}: {}\n", doc.name(), outage);
    return std::nullopt;
  }
  for (int m = 0; m < 2; ++m) {
    const char* muscle = m == 0 ? "agonist" : "antagonist";
    if (request.case_name != std::string("calibration_") + muscle) continue;
    if (!scenario.excitation[m]) {
      fmt::print(stderr, "config error: {}: no calibration.{} section to serve --case {}\n", doc.name(), muscle, request.case_name);
      return std::nullopt;
    }
    BoardPlant plant = board_for(*scenario.link, scenario.period_s, e1_recording_hardware(scenario, scenario.plant, m),
                                 fmt::format("one-DOF rig for peha record-calibration --muscle {} ({} kg, pinned for the tare and the clamped "
                                             "segments)",
                                             muscle, scenario.excitation[m]->payload_kg));
    // The recording sweeps the link onto its stops on purpose: the operator turns the rig's
    // procedure key for it, so the board's range cuts the motor but does not vent (docs/safety.md).
    if (const std::optional<mfb::DigitalLine>& key = plant.maps.front().procedure_key_line()) {
      plant.input_hook = [line = *key](double, mfb::BoardInputs& in) { line.set(in.digital_in, true); };
      plant.what += fmt::format(", the procedure key (input line {}) turned", key->line);
    }
    return plant;
  }
  std::vector<std::string> names;
  for (const auto& c : scenario.cases) names.push_back(c.name);
  const std::optional<std::size_t> i =
      emulator_case(doc, names, request.case_name, "the payload the simulated rig carries", "calibration_agonist, calibration_antagonist");
  if (!i) return std::nullopt;
  const E1Case& c = scenario.cases[*i];
  return board_for(*scenario.link, scenario.period_s, e1_hardware(scenario, c), fmt::format("one-DOF rig, case {} ({} kg)", c.name, c.payload_kg));
}

}  // namespace

Experiment e1_experiment() {
  Takes takes;
  takes.cases = takes.calibration = takes.force_trim = takes.faults = takes.boards = takes.replay = true;
  return {"gravity_compensation_1dof", "one-DOF rig", "E1: gravity compensation of the one-DOF PEHA rig with each payload (configs/e1_one_dof.yaml)",
          {{"", "E1 gravity compensation", takes,
            [](const config::Document& doc, const RunRequest& request) { return std::make_unique<E1Job>(doc, request); }}},
          check_e1, e1_board};
}

}  // namespace peha::experiments
