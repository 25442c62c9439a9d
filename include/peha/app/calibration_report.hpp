#pragma once
/// \file
/// The report folder of `peha calibrate`: predictions.csv (per row), spgp_grid.csv and
/// pseudo_inputs.csv (with an SPGP), summary.txt (also printed) and, with `plot`, report.png.

#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/dataset.hpp"

#include "peha/experiments/calibration_recording/acceptance.hpp"

#include <filesystem>

namespace peha::app {

/// Where the controller worked in the closed-loop check, for one muscle (`peha calibrate --scenario`).
struct ReportOperatingPoints {
  const experiments::AcceptanceResult* check = nullptr;
  int index = 0;  ///< 0 agonist, 1 antagonist: the calibrated muscle
};

/// With `points.check`, also operating_points.csv (per hold of the check: contraction, force request,
/// load cell, pressure command, the SPGP's mean and predictive std there), drawn
/// over the data in report.png.
void write_calibration_report(const std::filesystem::path& dir, const calibration::Dataset& data,
                              const calibration::CalibrationOutcome& outcome, bool plot,
                              const ReportOperatingPoints& points = {});

}  // namespace peha::app
