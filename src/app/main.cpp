// peha: control software for exoskeletons driven by pneumatic-electric hybrid actuators.
#include "peha/app/commands.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <mujoco/mujoco.h>

int main(int argc, char** argv) {
  CLI::App app{
      "peha - control software for exoskeletons driven by pneumatic-electric hybrid actuators\n"
      "(pneumatic artificial muscles + geared motors, forces through Bowden cables; Noda et al., IROS 2014).\n"
      "Every command runs on the simulated exoskeleton unless told otherwise."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("peha 0.1.0"));

  peha::app::RunOptions run;
  std::uint64_t seed = 0;
  CLI::App* run_cmd = app.add_subcommand(
      "run", "Run a scenario (an experiment described in a YAML config) on the simulated exoskeleton.\n"
             "Writes <out>/<run>/: one per-cycle CSV log per case (time first, units in column names),\n"
             "config.yaml (the config it ran with), summary.csv and plot.png; prints a summary table.\n"
             "Exit code 0 = ran and every safety figure held, 2 = bad config, 3 = a safety figure was violated.");
  run_cmd->add_option("-c,--config", run.config, "Scenario YAML, e.g. configs/e1_one_dof.yaml")
      ->required()->check(CLI::ExistingFile);
  run_cmd->add_option("-o,--out", run.out_root, "Directory under which the run directory is created")
      ->capture_default_str();
  run_cmd->add_option("-n,--name", run.run_name, "Run directory name (default: <config stem>-<UTC time>)");
  run_cmd->add_option("--case", run.only_case, "Run only the case with this name (default: all cases)");
  CLI::Option* seed_opt = run_cmd->add_option("--seed", seed, "Override the scenario's random seed (sensor noise)");
  run_cmd->add_flag("!--no-plot", run.plot, "Do not render plot.png (no Python needed)");

  std::filesystem::path check_path;
  CLI::App* check_cmd = app.add_subcommand(
      "check-config", "Parse and validate a scenario YAML without running it. Unknown keys, missing keys, wrong\n"
                      "types and out-of-range values are reported with file:line:column, key path and reason.");
  check_cmd->add_option("-c,--config", check_path, "Scenario YAML to check")->required()->check(CLI::ExistingFile);

  CLI::App* version_cmd = app.add_subcommand("version", "Print peha's and MuJoCo's versions.");

  CLI11_PARSE(app, argc, argv);

  if (*run_cmd) {
    if (*seed_opt) run.seed = seed;
    return peha::app::run(run);
  }
  if (*check_cmd) return peha::app::check_config(check_path);
  if (*version_cmd) {
    fmt::print("peha 0.1.0 (MuJoCo {})\n", mj_versionString());
    return 0;
  }
  return 0;
}
