// `peha calibrate`: the muscle model fitted to a calibration CSV, the calibration file and its report.
#include "peha/app/calibration_report.hpp"
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>

namespace peha::app {

int calibrate(const CalibrateCommandOptions& options) {
  return with_exit_codes([&] {
    calibration::DatasetRules rules;
    rules.min_rows = options.min_rows;
    refuse_output_equal_to_input(options.out, {options.data});
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
    experiments::ProgressPrinter lm("LM restarts"), gp("SPGP training");
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
    write_calibration_report(report, data, outcome, options.plot);
    fmt::print("written: {} and {}/\n", options.out.string(), report.string());
    return 0;
  });
}

}  // namespace peha::app
