#pragma once
/// \file
/// E5's run sequence for `peha run` (every case, in-process or one on the board) and what it writes
/// and prints: summary.csv, the per-case logs e5_<case>.csv, the table and the plot.

#include "peha/config/reader.hpp"
#include "peha/experiments/e5_max_force/max_force.hpp"
#include "peha/experiments/run_request.hpp"

#include <filesystem>
#include <vector>

namespace peha::experiments {

/// summary.csv: one row per case, every figure with its threshold.
void write_e5_summary(const std::filesystem::path& path, const std::vector<E5Result>& results);

/// The table of cases with each verdict; true when every check of every case passed.
bool print_e5_table(const std::vector<E5Result>& results);

/// `peha run` of an E5 scenario: exit code 0 (every figure held), 2 (bad request) or 3.
int run_e5_experiment(const config::Document& doc, const RunRequest& request);

}  // namespace peha::experiments
