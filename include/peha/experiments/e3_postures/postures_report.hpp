#pragma once
/// \file
/// E3's run for `peha run --experiment postures` (in-process or on the board) and what it
/// writes and prints: e3_postures.csv, summary.csv and the table of drifts with the safety figures.

#include "peha/config/reader.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/common/experiment.hpp"

#include <filesystem>
#include <memory>

namespace peha::experiments {

/// summary.csv of E3 and the table of postures; the table's drift column names `observe_s`.
void write_postures_summary(const std::filesystem::path& path, const PosturesResult& r, double observe_s);

/// E3's run (`peha run --experiment postures`, the arm's contract: arm_contract.hpp): the
/// scenario's postures in one script, in process or on the board(s).
std::unique_ptr<ExperimentRun> make_postures_run(const config::Document& doc, const RunRequest& request);

}  // namespace peha::experiments
