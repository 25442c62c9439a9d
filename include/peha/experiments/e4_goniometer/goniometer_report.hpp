#pragma once
/// \file
/// E4's run for `peha run --experiment goniometer` (in-process: every movement or a
/// recording, both variants; on the board: one movement, both variants) and what it writes and
/// prints: e4_<movement>_<variant>.csv, summary.csv, goniometer_<movement>.csv and the tables.

#include "peha/config/reader.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/experiments/common/experiment.hpp"

#include <memory>
#include <vector>

namespace peha::experiments {

/// The tables of the in-process results (tracking, then safety); true when every safety figure held.
bool print_goniometer_tables(const std::vector<GoniometerResult>& results);

/// E4's run (`peha run --experiment goniometer`, the arm's contract: arm_contract.hpp): every
/// movement (--case: one) or a recording (--goniometer-csv), open-loop and feedback each, in process;
/// one movement on the board.
std::unique_ptr<ExperimentRun> make_goniometer_run(const config::Document& doc, const RunRequest& request);

}  // namespace peha::experiments
