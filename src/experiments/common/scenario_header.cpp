#include "peha/experiments/common/scenario_header.hpp"

#include "peha/models/units.hpp"

namespace peha::experiments {

ScenarioHeader read_scenario_header(config::Map& root, const char* experiment) {
  ScenarioHeader h;
  root.choice("experiment", {experiment});
  h.description = root.string("description");
  h.seed = static_cast<std::uint64_t>(root.integer("seed", 0, 1L << 40));
  return h;
}

safety::LimitsModel read_one_joint_limits(config::Map& limits, double period_s) {
  using models::deg_to_rad, models::rad_to_deg;
  safety::LimitsModel m;
  safety::JointLimits& jl = m.joints[0];
  m.joint_count = 1;
  m.period_s = period_s;
  jl.pressure_rate_Pa_per_s = limits.number("pressure_rate_MPa_per_s", {0.01, 100.0}) * 1e6;
  jl.motor_rate_Nm_per_s = limits.number("motor_rate_Nm_per_s", {0.1, 1e5});
  jl.min_angle_rad = deg_to_rad(limits.number("min_angle_deg", {-180.0, 180.0}));
  jl.max_angle_rad = deg_to_rad(limits.number("max_angle_deg", {rad_to_deg(jl.min_angle_rad), 180.0}));
  limits.finish();
  return m;
}

}  // namespace peha::experiments
