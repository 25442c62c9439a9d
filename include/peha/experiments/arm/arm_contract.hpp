#pragma once
/// \file
/// The arm (`experiment: arm`, configs/right_arm.yaml, configs/upper_body.yaml) under the experiment
/// contract: three runs chosen by --experiment (E3 postures, E4 goniometer, E6 bandwidth), one
/// scenario check, and the emulator's arm for E3, E4, the gravity identification and a user's own
/// controller.

#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/experiments/common/experiment.hpp"

namespace peha::experiments {

Experiment arm_experiment();

/// The arm scenario of a run, with the request's seed, force trim and gravity identification.
/// Throws RequestError when the scenario's faults: list is given to a run other than E3's
/// (`takes_faults` false; `what` names the run in the message).
ArmScenario arm_scenario_for_run(const config::Document& doc, const RunRequest& request, const char* what, bool takes_faults);

}  // namespace peha::experiments
