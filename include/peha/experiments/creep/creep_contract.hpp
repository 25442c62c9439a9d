#pragma once
/// \file
/// The wire-creep experiment (`experiment: wire_creep`) under the experiment contract: a long E1-like
/// run of one case per plant variant x force-trim rate x estimator off/on, in process only (it
/// judges the estimate against the plant's true creep).

#include "peha/experiments/common/experiment.hpp"

namespace peha::experiments {

Experiment creep_experiment();

}  // namespace peha::experiments
