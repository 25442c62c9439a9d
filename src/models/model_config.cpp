#include "peha/models/model_config.hpp"

#include "peha/models/units.hpp"

namespace peha::models {

TendonSpringParams read_tendon_spring(config::Map map) {
  TendonSpringParams p;
  constexpr double kPerMPa = 1e-6;  // N/MPa -> N/Pa
  p.a_N_per_Pa = map.number("a_N_per_MPa", {-1e6, 1e6}) * kPerMPa;
  p.b_N_per_Pa = map.number("b_N_per_MPa", {-1e6, 1e6}) * kPerMPa;
  p.c_N_per_Pa = map.number("c_N_per_MPa", {1.0, 1e6}) * kPerMPa;
  p.k_N = map.number("k_N", {1.0, 1e9});
  p.eps0 = map.number("eps0", {-0.2, 0.2});
  map.finish();
  return p;
}

BowdenParams read_bowden(config::Map map) {
  BowdenParams p;
  p.friction_coefficient = map.number("friction_coefficient", {0.0, 1.0});
  p.wrap_angle_rad = deg_to_rad(map.number("wrap_angle_deg", {0.0, 1080.0}));
  p.sigmoid_gain_s_per_m = map.number("sigmoid_gain_s_per_m", {0.0, 1e6});
  map.finish();
  return p;
}

MuscleModel read_muscle_model(config::Map map, const std::string& name) {
  MuscleModel m;
  m.name = name;
  m.rest_length_m = map.number("rest_length_m", {0.05, 2.0});
  m.contraction_at_zero_angle = map.number("contraction_at_zero_angle", {-0.05, 0.3});
  m.max_force_N = map.number("max_force_N", {1.0, kMaxPamForce_N});
  m.pam = read_tendon_spring(map.map("pam"));
  m.bowden = read_bowden(map.map("bowden"));
  map.finish();
  return m;
}

JointModel read_joint_model(config::Map& map, const std::string& name, double supply_pressure_Pa, double pretension_N) {
  JointModel j;
  j.name = name;
  j.supply_pressure_Pa = supply_pressure_Pa;
  j.pretension_N = pretension_N;
  j.pulley_radius_m = map.number("pulley_radius_m", {0.005, 0.2});
  j.has_motor = map.boolean("has_motor");
  j.motor_max_torque_Nm = map.number("motor_max_torque_Nm", {0.0, 50.0});
  j.agonist = read_muscle_model(map.map("agonist"), "agonist");
  j.antagonist = read_muscle_model(map.map("antagonist"), "antagonist");
  return j;
}

}  // namespace peha::models
