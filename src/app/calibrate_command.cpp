// `peha calibrate`: the muscle model fitted to a calibration CSV, the calibration file and its report.
#include "peha/app/calibration_report.hpp"
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/config/csv_sidecar.hpp"
#include "peha/experiments/calibration_recording/acceptance.hpp"
#include "peha/experiments/run_request.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/plant_muscle.hpp"

#include <fmt/format.h>

#include <optional>

namespace peha::app {

int calibrate(const CalibrateCommandOptions& options) {
  return with_exit_codes([&] {
    calibration::DatasetRules rules;
    rules.min_rows = options.min_rows;
    if (!options.other_calibration.empty() && options.scenario.empty()) {
      fmt::print(stderr, "error: --other-calibration is for the closed-loop check: it needs --scenario\n");
      return 2;
    }
    std::vector<std::filesystem::path> inputs = {options.data, options.other_calibration};
    if (!options.scenario.empty()) {
      const std::vector<std::filesystem::path> more = scenario_inputs(options.scenario);
      inputs.insert(inputs.end(), more.begin(), more.end());
    }
    refuse_unsafe_output(options.out, inputs);
    calibration::CalibrateOptions o;
    // The muscle the file is for: peha run refuses a calibration of another muscle, so a guess (the
    // file's stem) would write a file every run refuses. The recording names it in its sidecar.
    const std::string recorded = calibration::recorded_muscle(options.data);
    if (!options.muscle.empty() && !recorded.empty() && options.muscle != recorded) {
      throw UsageError(fmt::format("--muscle {}, but {} is the recording of the {} ({}); calibrate each muscle from its own recording",
                                   options.muscle, options.data.string(), recorded, config::csv_sidecar_path(options.data).string()));
    }
    o.muscle = options.muscle.empty() ? recorded : options.muscle;
    if (o.muscle.empty()) {
      throw UsageError(fmt::format("which muscle is {} of? Its sidecar names none: give --muscle NAME, the muscle peha run will use "
                                   "it for (agonist or antagonist on the E1 rig); nothing written",
                                   options.data.string()));
    }
    // With a scenario: the muscle it calibrates, checked before anything runs; its plant law's
    // ceiling bounds the data's forces.
    std::optional<experiments::E1Scenario> scenario;
    int index = 0;
    if (!options.scenario.empty()) {
      if (o.muscle != "agonist" && o.muscle != "antagonist") {
        fmt::print(stderr, "error: --scenario needs --muscle agonist or antagonist (the muscle of the rig), found '{}'\n", o.muscle);
        return 2;
      }
      index = o.muscle == "agonist" ? 0 : 1;
      scenario = experiments::read_e1(config::Document::load_file(options.scenario));
      if (!scenario->acceptance) {
        fmt::print(stderr, "config error: {}: no calibration.acceptance section (the closed-loop check to run)\n",
                   options.scenario.string());
        return 2;
      }
      const sim::PlantMuscleParams& law = index == 0 ? scenario->plant.joint.agonist.law : scenario->plant.joint.antagonist.law;
      rules.max_force_N = sim::force_ceiling_N(law);
      rules.max_force_reason = fmt::format("the ceiling of {}'s {} plant law, {} at {} MPa stretched to contraction {}", options.scenario.string(),
                                           o.muscle, law.name, law.max_pressure_Pa * 1e-6, law.elastic_knee_contraction);
    }
    const calibration::Dataset data = calibration::read_dataset(options.data, rules);
    o.fit.restarts = options.restarts;
    o.fit.threads = options.threads;
    o.fit.seed = options.seed;
    o.spgp.num_pseudo = options.pseudo_inputs;
    o.spgp.max_iterations = options.spgp_iterations;
    o.spgp.seed = options.seed;
    o.use_spgp = options.use_spgp;
    o.holdout = options.holdout;
    fmt::print("peha calibrate: {} ({} rows, sha256 {}...)\n", options.data.string(), data.size(), data.sha256.substr(0, 12));
    experiments::ProgressPrinter lm("LM restarts"), gp("SPGP training");
    calibration::CalibrateProgress progress;
    progress.restarts = [&](int done, int total) { lm.update(done, total, fmt::format("{}/{}", done, total)); };
    progress.spgp = [&](int iteration, double nlml) {
      gp.update(iteration, options.spgp_iterations, fmt::format("NLML {:.1f}", nlml));
    };
    const calibration::CalibrationOutcome outcome = calibration::calibrate(data, o, progress);
    std::filesystem::path report = options.report_dir;
    if (report.empty()) report = std::filesystem::path(options.out).replace_extension().string() + "_report";
    std::optional<experiments::AcceptanceResult> check;
    if (scenario) {
      // The file's checks first (as peha run applies it), then the closed loop on the scenario's rig;
      // the other muscle keeps the scenario's model (the link is clamped: each muscle's force
      // follows its own pressure).
      experiments::E1Scenario s = *scenario;
      const safety::JointLimits& range = s.limits.joints[0];
      calibration::apply_calibration(outcome.calibration, options.out, options.use_spgp, s.controller.joint, index,
                                     range.min_angle_rad, range.max_angle_rad);
      if (!options.other_calibration.empty()) {
        // The pair as peha run uses it: the nominal model of the other muscle can be far enough off
        // the rig that the clamp carries the difference and this muscle's wire, not its model, decides.
        const calibration::MuscleCalibration other = calibration::read_calibration(options.other_calibration);
        calibration::apply_calibration(other, options.other_calibration, true, s.controller.joint, 1 - index, range.min_angle_rad,
                                       range.max_angle_rad);
      }
      fmt::print("closed-loop check on the rig ({}): holds at", options.scenario.string());
      for (double a : s.acceptance->angles_rad) fmt::print(" {:.0f}", models::rad_to_deg(a));
      fmt::print(" deg x {} payload(s), {:.1f} s each, pure feed-forward\n", s.cases.size(), s.acceptance->hold_s);
      check = experiments::run_acceptance_check(s, *s.acceptance, [](const experiments::E1Scenario& sc, const experiments::E1Case& c) {
        return experiments::e1_plant_params(sc, c);
      });
      fmt::print("  {}: force tracking RMS {:.1f} N (<= {:.1f}), lowest load-cell force {:.1f} N (>= {:.1f}): {}\n", o.muscle,
                 check->force_tracking_rms_N[index], check->max_rms_N[index], check->min_loadcell_N[index], check->min_tension_N,
                 check->passed(index) ? "accepted" : "REFUSED");
    }
    write_calibration_report(report, data, outcome, options.plot, {check ? &*check : nullptr, index});
    if (check && !check->passed(index)) {
      fmt::print(stderr, "calibration refused: closed-loop check on the rig: {}; {} not written (report: {}/)\n",
                 check->failure(index), options.out.string(), report.string());
      return 2;
    }
    if (options.out.has_parent_path()) std::filesystem::create_directories(options.out.parent_path());
    calibration::write_calibration(options.out, outcome.calibration);
    fmt::print("written: {} and {}/\n", options.out.string(), report.string());
    return 0;
  });
}

}  // namespace peha::app
