#pragma once
/// \file
/// E6's run for `peha run --experiment bandwidth` (in-process only) and what it writes and
/// prints: bode.csv and the gain/phase table with the -3 dB bandwidth and safety figures.

#include "peha/config/reader.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth.hpp"
#include "peha/experiments/common/experiment.hpp"

#include <filesystem>
#include <memory>
#include <vector>

namespace peha::experiments {

/// bode.csv and the tables of the PAM-only [0] and hybrid [1] sweeps; true when every safety figure held.
bool write_bandwidth_report(const std::filesystem::path& bode_csv, const std::vector<BandwidthResult>& results);

/// E6's run (`peha run --experiment bandwidth`, the arm's contract: arm_contract.hpp), in process only.
std::unique_ptr<ExperimentRun> make_bandwidth_run(const config::Document& doc, const RunRequest& request);

}  // namespace peha::experiments
