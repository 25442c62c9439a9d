#pragma once
/// \file
/// The experiments `peha` knows, keyed by a scenario's `experiment:` value: one row per experiment,
/// each its contract (experiments/common/experiment.hpp: what it takes, runs, checks and simulates
/// behind the board emulator). The one place the CLI learns what a scenario is.

#include "peha/config/reader.hpp"
#include "peha/experiments/common/experiment.hpp"

#include <vector>

namespace peha::app {

using experiments::BoardPlant;
using experiments::Experiment;
using experiments::RunVariant;
using experiments::ScenarioCheck;

/// Every experiment, in the order of `peha run --help`.
const std::vector<Experiment>& experiment_registry();

/// The entry of the scenario's `experiment:` value. Throws config::Error (file:line:column) when
/// the key is missing or names no known experiment, listing the known ones.
const Experiment& find_experiment(const config::Document& doc);

}  // namespace peha::app
