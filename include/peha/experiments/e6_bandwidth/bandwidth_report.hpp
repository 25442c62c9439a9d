#pragma once
/// \file
/// E6's run sequence for `peha run --experiment bandwidth` (in-process only) and what it writes and
/// prints: bode.csv and the gain/phase table with the -3 dB bandwidth and safety figures.

#include "peha/config/reader.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth.hpp"
#include "peha/experiments/run_request.hpp"

#include <filesystem>
#include <vector>

namespace peha::experiments {

/// bode.csv and the tables of the PAM-only [0] and hybrid [1] sweeps; true when every safety figure held.
bool write_bandwidth_report(const std::filesystem::path& bode_csv, const std::vector<BandwidthResult>& results);

/// `peha run --experiment bandwidth`: `scenario` is read and overridden (seed, force trim).
/// Exit code 0 (every safety figure held) or 3.
int run_bandwidth_experiment(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request);

}  // namespace peha::experiments
