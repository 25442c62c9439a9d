#pragma once
/// \file
/// The report folder of `peha calibrate`: predictions.csv (per row), spgp_grid.csv and
/// pseudo_inputs.csv (with an SPGP), summary.txt (also printed) and, with `plot`, report.png.

#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/dataset.hpp"

#include <filesystem>

namespace peha::app {

void write_calibration_report(const std::filesystem::path& dir, const calibration::Dataset& data,
                              const calibration::CalibrationOutcome& outcome, bool plot);

}  // namespace peha::app
