#pragma once
/// \file
/// What E5 writes and prints: summary.csv and the table with each case's verdict (its run:
/// e5_contract.hpp).

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

}  // namespace peha::experiments
