#pragma once
/// \file
/// The one-DOF rig's sensor check (`peha check-sensors`, docs/calibration.md "Sensor check"): each
/// load cell's vented zero, then a known mass on the link swept slowly up and down through a known
/// angle, so each cell's effective gain (its gain x the controller's pulley radius / the rig's) is
/// found from what the rig measures. Two runs, each started with the link on its pin and both
/// muscles vented (the start-up's rule, docs/safety.md), the known mass on the link: (0) the
/// antagonist vented; (1) the antagonist held near a known force. While the link slides up the
/// agonist's pulley end carries F/k, down F k (k the capstan ratio of its cable), so the geometric
/// mean of both sweeps is the static force; against the known torque (the mass's, plus the link's
/// own from the scenario's gravity model) it gives the agonist; run 1 gives the antagonist against
/// the agonist just found. The pulley radius
/// cannot be told from the cells' gain on this rig (no wire travel is measured): for torque only their
/// product matters, and that is what is corrected.

#include "peha/calibration/sensor_corrections.hpp"
#include "peha/config/reader.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/sensor_check/sensor_check_params.hpp"
#include "peha/io/backend.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"

#include <array>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace peha::experiments {

/// What one run measured (muscle index 0 agonist, 1 antagonist; sweep 0 up, 1 down).
struct SensorCheckRun {
  double zero_N[2] = {0, 0};           ///< mean reading while vented (the tare window)
  double code0_fraction[2] = {0, 0};   ///< share of those samples at the channel's code 0
  double reading_N[2][2] = {};         ///< [sweep][muscle]: mean reading in the window, less the zero
  double samples[2] = {0, 0};          ///< [sweep]
  int timed_out_leg = -1;              ///< the sweep leg (0..2) the link did not finish in time (-1: none)
  std::uint64_t faults = 0;
  std::string fault_reason;
};

/// The per-cycle log of a run: what the sensors gave, the reference and what was sent.
const std::vector<std::string>& sensor_check_log_columns();

/// Runs one of the two runs (`run` 0: the antagonist vented, 1: held at params.antagonist_force_N) on
/// `backend` (the rig with the known mass, the link pinned at 0 until params.pin_s). Only the rig's
/// sensors are read.
SensorCheckRun record_sensor_check_run(const E1Scenario& scenario, const SensorCheckParams& params, int run, io::Backend& backend,
                                       const runtime::CycleHooks& hooks = {}, runtime::RowSink* log = nullptr);

/// Refused by the procedure: what failed, in words (nothing is written).
struct SensorCheckRejected : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SensorCheckResult {
  std::array<SensorCheckRun, 2> runs;
  calibration::SensorCorrections corrections;
  double capstan_ratio = 0;          ///< the agonist cable's k from run 0
  double known_torque_Nm = 0;        ///< the known mass's and the link's torque at the check angle
};

/// The corrections from both runs' measurements; throws SensorCheckRejected when a cell's zero is
/// below its range or beyond max_zero_N, a window had no sample, or a gain leaves the accepted band.
SensorCheckResult fit_sensor_check(const E1Scenario& scenario, const SensorCheckParams& params, const std::array<SensorCheckRun, 2>& runs);

/// The simulated rig of either run: `plant` with no finger pushes, the pin at 0 until params.pin_s,
/// and `placed_mass_kg` on the link (what really is there; params.known_mass_kg is what the operator
/// believes).
sim::OneDofRigParams sensor_check_plant_params(const SensorCheckParams& params, sim::OneDofRigParams plant, double placed_mass_kg);

/// The whole procedure on the in-process rig `plant` (its sensor errors are what is found).
SensorCheckResult check_sensors(const E1Scenario& scenario, const SensorCheckParams& params, const sim::OneDofRigParams& plant,
                                double placed_mass_kg, const std::function<void(const std::string&)>& progress = {},
                                const std::function<runtime::RowSink*(int run)>& log = {});

}  // namespace peha::experiments
