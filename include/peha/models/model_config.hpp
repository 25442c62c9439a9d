#pragma once
/// \file
/// Reading the controller's models from YAML (strict: see config/reader.hpp).

#include "peha/config/reader.hpp"
#include "peha/models/joint.hpp"

namespace peha::models {

/// Keys: a_N_per_MPa, b_N_per_MPa, c_N_per_MPa (g(u) in N/MPa, as calibration reports them),
/// k_N, eps0.
TendonSpringParams read_tendon_spring(config::Map map);
/// Keys: friction_coefficient, wrap_angle_deg, sigmoid_gain_s_per_m.
BowdenParams read_bowden(config::Map map);
/// Keys: rest_length_m, contraction_at_zero_angle, max_force_N, pam{...}, bowden{...}.
MuscleModel read_muscle_model(config::Map map, const std::string& name);
/// Keys: pulley_radius_m, has_motor, motor_max_torque_Nm, agonist{...}, antagonist{...}. The supply
/// (from the scenario's limits) and the pretension (from its allocation) complete the joint set-up.
JointModel read_joint_model(config::Map& map, const std::string& name, double supply_pressure_Pa, double pretension_N);

}  // namespace peha::models
