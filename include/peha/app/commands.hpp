#pragma once
/// \file
/// The `peha` sub-commands, callable from the CLI and from tests.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace peha::app {

struct RunOptions {
  std::filesystem::path config;           ///< scenario YAML
  std::filesystem::path out_root = "out"; ///< run directories go under it
  std::string run_name;                   ///< default: <config stem>-<UTC time stamp>
  std::optional<std::uint64_t> seed;      ///< overrides the scenario's seed
  std::string only_case;                  ///< run only this case (empty: all)
  bool plot = true;                       ///< render plot.png with tools/plot_run.py
};

/// `peha run`: runs the scenario's experiment, writes out/<run>/ and prints a summary table.
/// Returns the process exit code (0 when every case ran and every safety figure held).
int run(const RunOptions& options);

/// `peha check-config`: parses and validates a scenario, prints what it would run. Exit code.
int check_config(const std::filesystem::path& config);

}  // namespace peha::app
