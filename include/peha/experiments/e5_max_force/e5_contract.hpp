#pragma once
/// \file
/// E5 (`experiment: max_force_ramp`) under the experiment contract: its cases are the clamp's
/// angles, each a pressure ramp of one muscle against its force ceiling, on the simulated rig, a
/// replayed log or the board.

#include "peha/experiments/common/experiment.hpp"

namespace peha::experiments {

Experiment e5_experiment();

}  // namespace peha::experiments
