#pragma once
/// \file
/// What E1 writes and prints: its model variants (calibrated or not), summary.csv and the table
/// with the safety figures (its run: e1_contract.hpp).

#include "peha/config/reader.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/run_request.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace peha::experiments {

/// One model the cases run with: the config's own (label empty), or a calibrated one.
struct E1Variant {
  std::string label;      ///< appended to the case names ("parametric", "spgp"); empty: the config's model
  E1Scenario scenario;
};

/// The config's own model, or - with calibration files (agonist [0], antagonist [1]; empty: none)
/// - the calibrated parametric model alone and with its SPGP residual, so the SPGP's effect is
/// measured in the same run. Prints which calibration each muscle got.
std::vector<E1Variant> e1_variants(const E1Scenario& scenario, const std::filesystem::path calibration[2]);

/// summary.csv: one row per release of each case.
void write_e1_summary(const std::filesystem::path& path, const std::vector<E1Result>& results);

/// The table of releases with each case's safety figures; true when every safety figure held.
bool print_e1_table(const std::vector<E1Result>& results);

}  // namespace peha::experiments
