#pragma once
/// \file
/// The keys every scenario starts with: which experiment it is, what it is for, and the seed of its
/// random numbers (sensor noise).

#include "peha/config/reader.hpp"
#include "peha/safety/limits.hpp"

#include <cstdint>
#include <string>

namespace peha::experiments {

struct ScenarioHeader {
  std::string description;
  std::uint64_t seed = 1;  ///< seed of the plant's random numbers; [0, 2^40]
};

/// Reads `experiment:` (must be `experiment`), `description:` and `seed:` from a scenario's root.
ScenarioHeader read_scenario_header(config::Map& root, const char* experiment);

/// The one-DOF rig's `limits:` keys besides `supply_pressure_MPa` (read by the caller before its
/// controller): pressure_rate_MPa_per_s, motor_rate_Nm_per_s, min_angle_deg, max_angle_deg; finishes
/// the map. One joint at `period_s`.
safety::LimitsModel read_one_joint_limits(config::Map& limits, double period_s);

}  // namespace peha::experiments
