#include "peha/sim/peha_joint_plant.hpp"

#include "peha/models/units.hpp"

#include "plant_muscle_law.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace peha::sim {
namespace {

CablePlantParams read_cable(config::Map map) {
  CablePlantParams c;
  c.kinetic_friction = map.number("kinetic_friction", {0.0, 1.0});
  c.static_friction = map.number("static_friction", {c.kinetic_friction, 1.0});
  c.stribeck_velocity_mps = map.number("stribeck_velocity_mps", {1e-6, 1.0});
  c.wrap_angle_rad = models::deg_to_rad(map.number("wrap_angle_deg", {0.0, 1080.0}));
  c.wire_stiffness_N_per_m = map.number("wire_stiffness_N_per_m", {1e3, 1e8});
  c.initial_slack_m = map.number("initial_slack_mm", {0.0, 50.0}) * 1e-3;
  c.creep_m_per_N_s = map.number("creep_m_per_N_s", {0.0, 1e-6});
  c.max_creep_m = map.number("max_creep_mm", {0.0, 20.0}) * 1e-3;
  map.finish();
  return c;
}

MusclePlantParams read_muscle(config::Map map, double supply_Pa) {
  MusclePlantParams m;
  m.law_file = map.path_value("law");
  m.law = load_plant_muscle(m.law_file);
  m.rest_length_m = map.number("rest_length_m", {0.05, 2.0});
  m.contraction_at_zero_angle = map.number("contraction_at_zero_angle", {-0.05, 0.3});
  m.initial_pressure_Pa = map.number("initial_pressure_MPa", {0.0, supply_Pa * 1e-6}) * 1e6;
  config::Map loadcell = map.map("loadcell");
  m.loadcell_noise_N = loadcell.number("noise_N", {0.0, 100.0});
  m.loadcell_range_N = loadcell.number("range_N", {100.0, 20000.0});
  m.loadcell_offset_N = loadcell.number_or("offset_N", 0.0, {-1000.0, 1000.0});
  m.loadcell_gain = loadcell.number_or("gain", 1.0, {0.5, 2.0});
  loadcell.finish();
  config::Map valve = map.map("valve");
  m.valve = read_valve(valve, supply_Pa);
  m.cable = read_cable(map.map("cable"));
  map.finish();
  return m;
}

}  // namespace

PehaJointPlantParams read_peha_joint_plant(config::Map& map, double supply_pressure_Pa, bool has_motor) {
  PehaJointPlantParams p;
  p.pulley_radius_m = map.number("pulley_radius_m", {0.005, 0.2});
  if (map.has("supply_cap_MPa")) p.supply_cap_Pa = map.number("supply_cap_MPa", {0.01, 1.0}) * 1e6;
  p.has_motor = has_motor;
  if (has_motor) {
    config::Map motor = map.map("motor");
    p.motor.gear_ratio = motor.number("gear_ratio", {1.0, 1000.0});
    p.motor.rotor_inertia_kgm2 = motor.number("rotor_inertia_kgm2", {0.0, 1e-2});
    p.motor.coulomb_friction_Nm = motor.number("coulomb_friction_Nm", {0.0, 10.0});
    p.motor.viscous_friction_Nms_per_rad = motor.number("viscous_friction_Nms_per_rad", {0.0, 10.0});
    p.motor.max_torque_Nm = motor.number("max_torque_Nm", {0.0, 50.0});
    motor.finish();
  }
  p.agonist = read_muscle(map.map("agonist"), supply_pressure_Pa);
  p.antagonist = read_muscle(map.map("antagonist"), supply_pressure_Pa);
  return p;
}

double quantize_16bit(double value, double range) noexcept {
  constexpr double kCodes = 65535.0;
  const double code = std::round(std::clamp(value / range, 0.0, 1.0) * kCodes);
  return code / kCodes * range;
}

double quantize_16bit_offset_binary(double value, double half_range) noexcept {
  const double step = 2.0 * half_range / 65536.0;
  const double code = std::clamp(std::round((value + half_range) / step), 0.0, 65535.0);
  return -half_range + code * step;
}

double redundant_encoder_angle_rad(double angle_rad, double counts_per_rev) noexcept {
  return counts_per_rev > 0 ? encoder_angle_rad(angle_rad, counts_per_rev) : std::numeric_limits<double>::quiet_NaN();
}

double encoder_angle_rad(double angle_rad, double counts_per_rev) noexcept {
  const double counts_per_rad = counts_per_rev / (2.0 * std::numbers::pi);
  return std::floor(angle_rad * counts_per_rad) / counts_per_rad;
}

double minimum_jerk(double s) noexcept {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
}

double read_timestep_s(config::Map& plant, double control_period_s) {
  const double timestep_s = plant.number("timestep_s", {1e-5, 0.01});
  const double ratio = control_period_s / timestep_s;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 || ratio < 1.0) {
    plant.fail("timestep_s", fmt::format("must divide the control period {} s, found {} s", control_period_s, timestep_s));
  }
  return timestep_s;
}

namespace {

/// The valve as this joint has it: its supply cut to the plant-only cap.
ValveParams capped(ValveParams v, double supply_cap_Pa) {
  v.supply_pressure_Pa = std::min(v.supply_pressure_Pa, supply_cap_Pa);
  return v;
}

}  // namespace

PehaJointPlant::PehaJointPlant(const PehaJointPlantParams& params, double timestep_s, double initial_angle_rad)
    : params_(params),
      timestep_s_(timestep_s),
      muscles_{{+1, Valve(capped(params_.agonist.valve, params_.supply_cap_Pa), timestep_s)},
               {-1, Valve(capped(params_.antagonist.valve, params_.supply_cap_Pa), timestep_s)}} {
  const CablePlantParams& ca = params_.agonist.cable;
  const CablePlantParams& cb = params_.antagonist.cable;
  cables_mirrored_ = muscles_[0].side == -muscles_[1].side && ca.kinetic_friction == cb.kinetic_friction &&
                     ca.static_friction == cb.static_friction && ca.stribeck_velocity_mps == cb.stribeck_velocity_mps &&
                     ca.wrap_angle_rad == cb.wrap_angle_rad;
  for (Muscle& mu : muscles_) {
    const MusclePlantParams& p = muscle_params(mu);
    mu.valve.reset(std::min(p.initial_pressure_Pa, params_.supply_cap_Pa));
    // Twice: the first solve finds the contraction, the second starts from it at zero rate.
    solve_muscle(mu, initial_angle_rad);
    solve_muscle(mu, initial_angle_rad);
    const int i = mu.side > 0 ? 0 : 1;
    // At rest the friction is static: the lowest tension along the wire is T*exp(-mu_s*psi).
    truth_.pulley_tension_min_N[i] = mu.tension_N * std::exp(-p.cable.static_friction * p.cable.wrap_angle_rad);
    truth_.joint_side_tension_N[i] = mu.tension_N;  // settled: no friction stored in the wire yet
    truth_.muscle_force_N[i] = mu.tension_N;
    truth_.pressure_Pa[i] = mu.valve.pressure_Pa();
    truth_.muscle_contraction[i] = mu.contraction;
  }
}

double PehaJointPlant::armature_kgm2() const {
  return params_.has_motor ? params_.motor.rotor_inertia_kgm2 * params_.motor.gear_ratio * params_.motor.gear_ratio : 0.0;
}
double PehaJointPlant::viscous_friction_Nms_per_rad() const {
  return params_.has_motor ? params_.motor.viscous_friction_Nms_per_rad : 0.0;
}
double PehaJointPlant::coulomb_friction_Nm() const { return params_.has_motor ? params_.motor.coulomb_friction_Nm : 0.0; }

void PehaJointPlant::solve_muscle(Muscle& mu, double angle) noexcept {
  const MusclePlantParams& p = muscle_params(mu);
  const double r0 = params_.pulley_radius_m;
  const double dt_s = timestep_s_;
  const double pressure = mu.valve.pressure_Pa();
  const double eps = p.contraction_at_zero_angle + mu.side * r0 * angle / p.rest_length_m;
  const int index = mu.side > 0 ? 0 : 1;
  const double base = eps + (p.cable.initial_slack_m + mu.creep_m + faults_.wire_slip_m[index]) / p.rest_length_m;
  if (faults_.wire_broken[index]) {  // nothing pulls on the muscle: it contracts freely, the wire carries nothing
    mu.tension_N = 0.0;
    return;
  }
  const double per_N = 1.0 / (p.cable.wire_stiffness_N_per_m * p.rest_length_m);
  // Equilibrium of a massless muscle on an elastic wire: T = F(P, u(T), du/dt(T)) with
  // u(T) = base + T*per_N. The contraction rate is taken implicitly, (u(T) - u_previous)/dt: with an
  // explicit rate the hysteresis term chatters, because a stiff wire turns a small change of force
  // into a large change of rate. phi(T) = F - T decreases strictly in T (the static force falls with
  // u and the hysteresis factor falls with the rate), so the root is unique and bracketed by
  // [0, F at T = 0]. Newton steps with a difference quotient, bisection when a step leaves the bracket.
  // The law's clamps and q(P) once per solve (the pressure holds during it); bit for bit force_N.
  const double u_previous = mu.contraction;
  const detail::MuscleLawAtPressure law(p.law, pressure);
  auto phi = [&](double T) {
    const double u = base + T * per_N;
    return law.force_N(u, (u - u_previous) / dt_s) - T;
  };
  //
  // The bracket's upper end phi(0) = F at zero tension costs an evaluation of the law, and the
  // iteration needs its value only when a step would leave the bracket or bisect. It is evaluated
  // when needed: F falls with T, so F(0) >= F(T) = T + phi(T) for any T >= 0 up to the law's
  // rounding (~1e-11 N at 10 kN), and while every residual so far is positive (hi is still phi(0))
  // a Newton step below T + phi(T) - margin is inside the bracket, and a residual >= 1e-7 keeps
  // hi - lo >= 1e-7. Every decision, hence every iterate, is the one the bracket with phi(0)
  // evaluated first makes: the same tension to the bit, ~one evaluation in five fewer.
  auto margin = [](double F) { return 1e-8 + 1e-12 * F; };  // >> the law's rounding
  double lo = 0.0;
  double hi = 0.0;
  bool hi_known = false;  // false: hi is phi(0), not evaluated yet
  auto evaluate_hi = [&]() {
    hi = phi(0.0);
    hi_known = true;
  };
  double T = mu.tension_N;
  // The first iterate's residual phi(T) (unless the clamp below moves T), as static force x factor.
  const double u_start = base + T * per_N;
  const double static_start = law.static_force_N(u_start);
  double r = static_start * law.hysteresis_factor((u_start - u_previous) / dt_s) - T;
  // The clamp of T into [0, phi(0)] leaves it alone if phi(0) >= T for sure: if phi(T) > margin,
  // or if the static force at u(T) (<= the static force at u(0) = base: it falls with u) times the
  // hysteresis factor at T = 0 (one tanh, mostly saturated) is above T by the margin.
  bool inside = T >= 0.0 && r >= margin(T + r);
  if (!inside && T >= 0.0) inside = static_start * law.hysteresis_factor((base - u_previous) / dt_s) >= T + margin(T);
  if (!inside) {
    evaluate_hi();
    if (!(hi > 0.0)) {
      T = 0.0;
    } else {
      const double clamped = std::clamp(T, lo, hi);
      if (clamped != T && !std::isnan(T)) {
        T = clamped;
        r = phi(T);
      }
    }
  }
  if (!hi_known || hi > 0.0) {
    for (int it = 0; it < 80; ++it) {
      if (it > 0) r = phi(T);
      if (r > 0.0) {
        lo = T;
      } else {
        hi = T;
        hi_known = true;
      }
      // Unknown hi: r > 0 so far, and here r >= 1e-7, hence phi(0) - lo >= 1e-7.
      if (std::abs(r) < 1e-7 || (hi_known && hi - lo < 1e-9)) break;
      const double h = 1e-6 * (1.0 + T);
      const double slope = (phi(T + h) - r) / h;
      double next = 0.0;
      if (slope < 0.0) {
        next = T - r / slope;
        if (!hi_known && !(next > lo && next <= (T + r) - margin(T + r))) evaluate_hi();
      } else {
        if (!hi_known) evaluate_hi();
        next = 0.5 * (lo + hi);
      }
      if (hi_known && !(next > lo && next < hi)) next = 0.5 * (lo + hi);
      T = next;
    }
  }
  mu.contraction = base + T * per_N;
  mu.tension_N = T;
}

PehaJointPlant::Forces PehaJointPlant::step(const io::JointCommand& cmd, double angle, double omega) noexcept {
  const double dt = timestep_s_;
  const double r0 = params_.pulley_radius_m;
  const double wanted[2] = {cmd.agonist_pressure_Pa, cmd.antagonist_pressure_Pa};
  for (int i = 0; i < 2; ++i) {
    Valve& valve = muscles_[i].valve;
    valve.set_supply_Pa(supply_Pa(muscle_params(muscles_[i])));
    double command = wanted[i];
    if (!faults_.dump && faults_.valve_stuck_open[i]) command = std::numeric_limits<double>::max();  // fills to supply
    if (!faults_.dump && faults_.valve_stuck_closed[i]) command = valve.pressure_Pa();             // holds its air
    valve.step(command);
  }
  // Capstan friction: the wire slides toward its muscle (v > 0) or away from it. Moving toward the
  // muscle the pulley end carries T*exp(-x); away, T*exp(+x). Around v = 0 the friction is static.
  // The two wires move at +-v: with mirrored cables (cables_mirrored_) the antagonist's exponentials
  // are the agonist's (the same arguments, bit for bit) and its tanh the agonist's negated (glibc's
  // tanh is odd), so they are computed once.
  struct Capstan {
    double exp_minus_x, exp_x, slide;  // slide = tanh(v / v_stribeck)
  };
  auto capstan = [&](const CablePlantParams& c, double v) noexcept -> Capstan {
    const double mu_eff = c.kinetic_friction + (c.static_friction - c.kinetic_friction) *
                                                   std::exp(-(v / c.stribeck_velocity_mps) * (v / c.stribeck_velocity_mps));
    const double x = mu_eff * c.wrap_angle_rad;
    return {std::exp(-x), std::exp(x), std::tanh(v / c.stribeck_velocity_mps)};
  };
  Capstan cap[2];
  cap[0] = capstan(params_.agonist.cable, muscles_[0].side * r0 * omega);
  if (cables_mirrored_) {
    cap[1] = {cap[0].exp_minus_x, cap[0].exp_x, -cap[0].slide};
  } else {
    cap[1] = capstan(params_.antagonist.cable, muscles_[1].side * r0 * omega);
  }
  double friction_Nm = 0.0;
  for (int k = 0; k < 2; ++k) {
    Muscle& mu = muscles_[k];
    solve_muscle(mu, angle);
    const CablePlantParams& c = muscle_params(mu).cable;
    mu.creep_m = std::min(mu.creep_m + c.creep_m_per_N_s * mu.tension_N * dt, c.max_creep_m);
    const double exp_minus_x = cap[k].exp_minus_x;
    const double toward = mu.tension_N * (1.0 - exp_minus_x);
    const double exp_x = cap[k].exp_x;
    const double away = mu.tension_N * (exp_x - 1.0);
    const double weight = 0.5 * (1.0 + cap[k].slide);  // which way it slides
    friction_Nm += r0 * (weight * toward + (1.0 - weight) * away);
    const int i = mu.side > 0 ? 0 : 1;
    truth_.pulley_tension_min_N[i] = mu.tension_N * exp_minus_x;
    truth_.joint_side_tension_N[i] = std::clamp(truth_.joint_side_tension_N[i], mu.tension_N * exp_minus_x, mu.tension_N * exp_x);
    truth_.muscle_force_N[i] = mu.tension_N;
    truth_.pressure_Pa[i] = mu.valve.pressure_Pa();
    truth_.muscle_contraction[i] = mu.contraction;
    truth_.creep_m[i] = mu.creep_m;
  }
  const double motor = params_.has_motor && !faults_.motor_failed ? std::clamp(std::isfinite(cmd.motor_torque_Nm) ? cmd.motor_torque_Nm : 0.0,
                                                      -params_.motor.max_torque_Nm, params_.motor.max_torque_Nm)
                                         : 0.0;
  truth_.motor_torque_Nm = motor;
  truth_.cable_friction_Nm = friction_Nm;
  truth_.joint_torque_after_cable_Nm = r0 * (truth_.joint_side_tension_N[0] - truth_.joint_side_tension_N[1]) + motor;
  return {r0 * (muscles_[0].tension_N - muscles_[1].tension_N) + motor, friction_Nm};
}

void PehaJointPlant::sense(double pressure_noise_Pa, double pressure_range_Pa, std::mt19937_64& rng,
                           io::JointSensors& s) noexcept {
  const double* force = truth_.muscle_force_N;
  auto loadcell = [&](const MusclePlantParams& p, double tension_N) {
    return quantize_16bit(p.loadcell_gain * tension_N + p.loadcell_offset_N + p.loadcell_noise_N * unit_normal_(rng),
                          p.loadcell_range_N);
  };
  const MusclePlantParams* p[2] = {&params_.agonist, &params_.antagonist};
  double cell[2], pressure[2];
  for (int i = 0; i < 2; ++i) {
    cell[i] = loadcell(*p[i], force[i] + faults_.loadcell_bias_N[i] + faults_.loadcell_drift_N[i]);
    if (faults_.loadcell_stuck[i]) cell[i] = last_loadcell_N_[i];
    if (faults_.loadcell_disconnected[i]) cell[i] = 0.0;
    if (faults_.loadcell_saturated[i]) cell[i] = p[i]->loadcell_range_N;
    last_loadcell_N_[i] = cell[i];
  }
  for (int i = 0; i < 2; ++i) {
    pressure[i] = quantize_16bit(truth_.pressure_Pa[i] + pressure_noise_Pa * unit_normal_(rng), pressure_range_Pa);
    if (faults_.pressure_sensor_failed[i]) pressure[i] = 0.0;
  }
  s.agonist_loadcell_N = cell[0];
  s.antagonist_loadcell_N = cell[1];
  s.agonist_pressure_Pa = pressure[0];
  s.antagonist_pressure_Pa = pressure[1];
  // The supply sensor on the valve manifold and the motor driver's current monitor: 16-bit channels
  // without noise of their own (no draw: the other sensors' noise sequence stays as it was).
  s.supply_pressure_Pa = quantize_16bit(supply_Pa(params_.agonist), pressure_range_Pa);
  if (params_.has_motor) {
    // Over +-(the rating x 1.2, rounded up to a whole Nm): the monitor reads a little past the
    // driver's limit (3 Nm for the 2.5 Nm motors, as the outputs).
    s.motor_torque_Nm = quantize_16bit_offset_binary(truth_.motor_torque_Nm, std::ceil(1.2 * params_.motor.max_torque_Nm - 1e-9));
  } else {
    s.motor_torque_Nm = std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace peha::sim
