#pragma once
/// \file
/// E3's run sequence for `peha run --experiment postures` (in-process or on the board) and what it
/// writes and prints: e3_postures.csv, summary.csv and the table of drifts with the safety figures.

#include "peha/config/reader.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/run_request.hpp"

#include <filesystem>
#include <optional>

namespace peha::experiments {

/// summary.csv of E3 and the table of postures; the table's drift column names `observe_s`.
void write_postures_summary(const std::filesystem::path& path, const PosturesResult& r, double observe_s);

/// `peha run --experiment postures`: `scenario` is read and overridden (seed, force trim);
/// `realtime` set runs it on the board. Exit code 0 (every safety figure held) or 3.
int run_postures_experiment(const config::Document& doc, const ArmScenario& scenario, const RunRequest& request,
                            std::optional<HardwareRunOptions> realtime);

}  // namespace peha::experiments
