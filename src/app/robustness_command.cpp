// `peha robustness`: the robustness matrix (plant variants x payloads x modes x seeds), its table,
// CSV and heat map.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/experiments/robustness/robustness.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>

namespace peha::app {

int robustness(const RobustnessOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    experiments::RobustnessConfig config = experiments::read_robustness(doc);
    if (options.threads) config.threads = *options.threads;
    if (!options.only_variant.empty()) {
      std::erase_if(config.variants, [&](const experiments::PlantVariant& v) { return v.name != options.only_variant; });
      if (config.variants.empty()) {
        fmt::print(stderr, "error: no variant named '{}' in {}\n", options.only_variant, doc.name());
        return 2;
      }
    }
    if (!options.only_mode.empty()) {
      std::erase_if(config.modes, [&](experiments::RobustnessMode m) { return experiments::to_string(m) != options.only_mode; });
      if (config.modes.empty()) {
        fmt::print(stderr, "error: mode '{}' is not on in {} (modes: {})\n", options.only_mode, doc.name(),
                   experiments::robustness_mode_names());
        return 2;
      }
    }
    RunDir run_dir(options.config, options.out_root, options.run_name, scenario_inputs(options.config));
    const std::filesystem::path dir = run_dir.create(config.seeds.front());
    if (options.keep_calibrations) {
      config.keep_calibrations_dir = dir / "calibrations";
      std::filesystem::create_directories(config.keep_calibrations_dir);
    }
    fmt::print("peha robustness: {}\n  {} variant(s) x modes {} x {} seed(s) on {} thread(s); output {}\n", doc.name(),
               config.variants.size(), [&] {
                 std::string m;
                 for (auto mode : config.modes) m += (m.empty() ? "" : ", ") + std::string(experiments::to_string(mode));
                 return m;
               }(), config.seeds.size(), config.threads, dir.string());
    std::fflush(stdout);
    const experiments::RobustnessResult result = experiments::run_robustness(
        config, [](std::size_t done, std::size_t total, const std::string& line) {
          fmt::print("  [{}/{}] {}\n", done, total, line);
          std::fflush(stdout);
        });
    experiments::write_robustness(dir, config, result);
    bool met = true;
    fmt::print("\n");
    for (const auto& s : result.shares) {
      met = met && s.ok();
      fmt::print("{:<17} goal met in {}/{} of the cases physics allows ({:.0f} %, required {:.0f} %): {}; physics forbids {} "
                 "more (reported, verdict FAIL); {}/{} of all\n",
                 s.mode, s.met, s.judged(), s.judged() ? 100.0 * s.met / s.judged() : 0.0, 100 * s.required, s.ok() ? "OK" : "MISSED",
                 s.forbidden, s.met, s.total);
    }
    fmt::print("written: {}/robustness.md, robustness.csv, config.yaml\n", dir.string());
    if (options.plot) experiments::plot_with("plot_robustness.py", dir);
    run_dir.commit();
    fmt::print("run folder: {}\n", run_dir.path().string());
    return met ? 0 : 3;
  });
}

}  // namespace peha::app
