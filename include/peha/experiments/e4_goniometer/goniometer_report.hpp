#pragma once
/// \file
/// E4's run sequence for `peha run --experiment goniometer` (in-process: every movement or a
/// recording, both variants; on the board: one movement, both variants) and what it writes and
/// prints: e4_<movement>_<variant>.csv, summary.csv, goniometer_<movement>.csv and the tables.

#include "peha/config/reader.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/experiments/run_request.hpp"

#include <optional>
#include <vector>

namespace peha::experiments {

/// The tables of the in-process results (tracking, then safety); true when every safety figure held.
bool print_goniometer_tables(const std::vector<GoniometerResult>& results);

/// `peha run --experiment goniometer`: `scenario` is read and overridden (seed, force trim);
/// `realtime` set runs it on the board. Exit code 0 (every safety figure held), 2 (bad request) or 3.
int run_goniometer_experiment(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request,
                              std::optional<HardwareRunOptions> realtime);

}  // namespace peha::experiments
