#pragma once
/// \file
/// The closed-loop acceptance check of a calibration (docs/calibration.md, "Acceptance on the rig"):
/// a few seconds of E1-like holding on the paper's pure feed-forward with the calibrated models,
/// judged by what the rig's sensors give (load cells, commanded forces), not by the pressure RMS of
/// the fit. A held-out pressure RMS of 2-4 kPa says nothing about a muscle at its pretension if the
/// data never went there; this check runs the controller where it works.

#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include <functional>
#include <string>
#include <vector>

namespace peha::experiments {

/// One hold of the check: where the controller worked (means over the judged samples).
struct AcceptancePoint {
  std::string case_name;
  double angle_deg = 0;                      ///< encoder
  double contraction[2] = {0, 0};            ///< rigid-wire contraction, controller's geometry (agonist, antagonist)
  double force_cmd_N[2] = {0, 0};            ///< the controller's force request
  double loadcell_N[2] = {0, 0};             ///< measured
  double pressure_cmd_Pa[2] = {0, 0};        ///< commanded
  double min_loadcell_N[2] = {0, 0};         ///< lowest over the judged samples
};

struct AcceptanceResult {
  std::vector<AcceptancePoint> points;       ///< cases x angles, in order
  double force_tracking_rms_N[2] = {0, 0};   ///< RMS(force request - load cell) over every judged sample
  double min_loadcell_N[2] = {0, 0};         ///< lowest load-cell force over every judged sample
  double force_request_rms_N[2] = {0, 0};    ///< RMS of the force request over the same samples
  /// The thresholds it was judged against: max(max_force_tracking_rms_N,
  /// max_force_tracking_rms_fraction x force_request_rms_N[i]) per muscle.
  double max_rms_N[2] = {0, 0};
  double min_tension_N = 0;                  ///< min_tension_fraction x pretension
  /// Muscle i (0 agonist, 1 antagonist) passed both figures.
  bool passed(int i) const noexcept {
    return force_tracking_rms_N[i] <= max_rms_N[i] && min_loadcell_N[i] >= min_tension_N;
  }
  /// "" when muscle i passed, else what failed with the numbers.
  std::string failure(int i) const;
};

/// Runs the check on `scenario` (its controller already carrying the calibrated models; the force
/// trim is switched off here) for every case of the scenario: the link is clamped at each of
/// `a.angles_rad`. `plant_of(s, c)` gives the rig of case `c` of the check's scenario `s` (its finger
/// pushes are the check's holds): e1_plant_params, or a robustness variant. Allocation-free only in
/// its control loop; set-up code.
AcceptanceResult run_acceptance_check(const E1Scenario& scenario, const CalibrationAcceptance& a,
                                      const std::function<sim::OneDofRigParams(const E1Scenario&, const E1Case&)>& plant_of);

}  // namespace peha::experiments
