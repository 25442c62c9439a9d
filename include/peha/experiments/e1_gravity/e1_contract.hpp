#pragma once
/// \file
/// E1 (`experiment: gravity_compensation_1dof`) under the experiment contract: its cases are the
/// payloads (each with the config's model, or the calibrated models with and without SPGP), on the
/// simulated rig, a replayed log or the board; the emulator serves its cases and the calibration
/// recordings (`--case calibration_agonist|antagonist`).

#include "peha/experiments/common/experiment.hpp"

namespace peha::experiments {

Experiment e1_experiment();

}  // namespace peha::experiments
