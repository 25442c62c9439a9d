#pragma once
/// \file
/// Shared inputs of the benchmark suite: the shipped E1 scenario and a closed-loop recording of its
/// 5.0 kg case on the simulated rig, so the control-side benchmarks run on realistic states and the
/// plant-side benchmarks on realistic commands. Built once, lazily, outside any timed region.

#include "peha/calibration/calibration_file.hpp"
#include "peha/control/allocation.hpp"
#include "peha/io/backend.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include <vector>

namespace peha::bench {

/// The shipped scenario, configs/e1_one_dof.yaml.
const experiments::E1Scenario& e1_scenario();

/// The scenario's 5.0 kg case (the heavier one).
const experiments::E1Case& e1_heavy_case();

/// One full closed-loop run of the heavy case (read -> update -> apply_limits -> write), exactly as
/// experiments::run_e1_case does it: duration_s / period_s + 1 samples.
struct E1Recording {
  std::vector<io::SensorState> states;                ///< what the controller read, per cycle
  std::vector<io::Command> commands;                  ///< what reached the plant (after the limits)
  std::vector<control::AllocationInput> allocation;   ///< what the controller handed to allocate()
};
const E1Recording& e1_recording();

/// Controller model / plant parameters of the heavy case (payload filled in as run_e1_case does).
control::OneDofControllerModel heavy_controller_model();
sim::OneDofRigParams heavy_plant_params();

/// An SPGP pressure residual like a calibration's (M = 50 pseudo-inputs over x = (eps, F), output in
/// Pa): fitted once on 3000 synthetic rows, a smooth surface of +-20 kPa plus 1 kPa noise, over the
/// data box eps [0, 0.25], F [0, 1500] N, residual range +-0.2 MPa.
std::shared_ptr<const calibration::SpgpResidual> synthetic_spgp_residual();

}  // namespace peha::bench
