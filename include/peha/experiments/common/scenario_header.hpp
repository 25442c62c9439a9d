#pragma once
/// \file
/// The keys every scenario starts with: which experiment it is, what it is for, and the seed of its
/// random numbers (sensor noise).

#include "peha/config/reader.hpp"

#include <cstdint>
#include <string>

namespace peha::experiments {

struct ScenarioHeader {
  std::string description;
  std::uint64_t seed = 1;  ///< seed of the plant's random numbers; [0, 2^40]
};

/// Reads `experiment:` (must be `experiment`), `description:` and `seed:` from a scenario's root.
ScenarioHeader read_scenario_header(config::Map& root, const char* experiment);

}  // namespace peha::experiments
