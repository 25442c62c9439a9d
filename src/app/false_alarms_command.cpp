// `peha false-alarms`: every plausibility check's statistic on fault-free runs, its table, CSV and figure.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/experiments/false_alarms/false_alarms.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdio>

namespace peha::app {

int false_alarms(const FalseAlarmsOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    experiments::FalseAlarmConfig config = experiments::read_false_alarms(doc);
    if (options.threads) config.threads = *options.threads;
    if (options.seeds) config.seeds = *options.seeds;
    if (options.variant_seeds) config.variant_seeds = *options.variant_seeds;
    RunDir run_dir(options.config, options.out_root, options.run_name, scenario_inputs(options.config));
    const std::filesystem::path dir = run_dir.create(1);
    fmt::print("peha false-alarms: {}\n  {} case(s) x noise x{} x {} seed(s), {} variant(s) x {} seed(s), on {} thread(s); output {}\n",
               doc.name(), config.cases.size(), fmt::format("{}", fmt::join(config.noise_scales, "/x")), config.seeds, config.variants.size(),
               config.variant_seeds, config.threads, dir.string());
    std::fflush(stdout);
    const experiments::FalseAlarmResult result =
        experiments::run_false_alarms(config, [](std::size_t done, std::size_t total, const std::string& line) {
          fmt::print("  [{}/{}] {}\n", done, total, line);
          std::fflush(stdout);
        });
    experiments::write_false_alarms(dir, config, result);
    fmt::print("\n{} runs. ", result.rows.size());
    if (result.passed()) {
      fmt::print("No false alarm at x1 or x{:g} noise; every margin at x1 >= {:g}: PASSED\n",
                 config.noise_scales.size() > 1 ? config.noise_scales[1] : 1.0, config.margin_goal);
    } else {
      fmt::print("FAILED ({} figures):\n", result.failures.size());
      for (const std::string& f : result.failures) fmt::print("  {}\n", f);
    }
    fmt::print("written: {}/false_alarms.md, false_alarms.csv, config.yaml\n", dir.string());
    if (options.plot) experiments::plot_with("plot_false_alarms.py", dir);
    run_dir.commit();
    fmt::print("run folder: {}\n", run_dir.path().string());
    return result.passed() ? 0 : 3;
  });
}

}  // namespace peha::app
