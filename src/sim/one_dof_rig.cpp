#include "peha/sim/one_dof_rig.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace peha::sim {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

CablePlantParams read_cable(config::Map map) {
  CablePlantParams c;
  c.kinetic_friction = map.number("kinetic_friction", {0.0, 1.0});
  c.static_friction = map.number("static_friction", {c.kinetic_friction, 1.0});
  c.stribeck_velocity_mps = map.number("stribeck_velocity_mps", {1e-6, 1.0});
  c.wrap_angle_rad = map.number("wrap_angle_deg", {0.0, 1080.0}) * kDegToRad;
  c.wire_stiffness_N_per_m = map.number("wire_stiffness_N_per_m", {1e3, 1e8});
  c.initial_slack_m = map.number("initial_slack_mm", {0.0, 50.0}) * 1e-3;
  c.creep_m_per_N_s = map.number("creep_m_per_N_s", {0.0, 1e-6});
  c.max_creep_m = map.number("max_creep_mm", {0.0, 20.0}) * 1e-3;
  map.finish();
  return c;
}

MusclePlantParams read_muscle(config::Map map, double control_dt_s, double supply_Pa) {
  (void)control_dt_s;
  MusclePlantParams m;
  m.law_file = map.path_value("law");
  m.law = load_plant_muscle(m.law_file);
  m.rest_length_m = map.number("rest_length_m", {0.05, 2.0});
  m.contraction_at_zero_angle = map.number("contraction_at_zero_angle", {-0.05, 0.3});
  m.initial_pressure_Pa = map.number("initial_pressure_MPa", {0.0, supply_Pa * 1e-6}) * 1e6;
  config::Map loadcell = map.map("loadcell");
  m.loadcell_noise_N = loadcell.number("noise_N", {0.0, 100.0});
  m.loadcell_range_N = loadcell.number("range_N", {100.0, 20000.0});
  loadcell.finish();
  config::Map valve = map.map("valve");
  m.valve = read_valve(valve, supply_Pa);
  m.cable = read_cable(map.map("cable"));
  map.finish();
  return m;
}

}  // namespace

OneDofRigParams read_one_dof_rig(config::Map& plant, double control_period_s, double supply_pressure_Pa) {
  OneDofRigParams p;
  p.control_period_s = control_period_s;
  p.supply_pressure_Pa = supply_pressure_Pa;
  p.model_file = plant.path_value("model");
  p.timestep_s = plant.number("timestep_s", {1e-5, 0.01});
  const double ratio = control_period_s / p.timestep_s;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 || ratio < 1.0) {
    plant.fail("timestep_s", fmt::format("must divide the control period {} s, found {} s",
                                         control_period_s, p.timestep_s));
  }
  p.pulley_radius_m = plant.number("pulley_radius_m", {0.005, 0.2});
  config::Map pressure = plant.map("pressure_sensor");
  p.pressure_noise_Pa = pressure.number("noise_MPa", {0.0, 0.1}) * 1e6;
  p.pressure_range_Pa = pressure.number("range_MPa", {0.1, 2.0}) * 1e6;
  pressure.finish();
  p.encoder_counts_per_rev = plant.number("encoder_counts_per_rev", {16, 1e9});
  config::Map motor = plant.map("motor");
  p.motor.gear_ratio = motor.number("gear_ratio", {1.0, 1000.0});
  p.motor.rotor_inertia_kgm2 = motor.number("rotor_inertia_kgm2", {0.0, 1e-2});
  p.motor.coulomb_friction_Nm = motor.number("coulomb_friction_Nm", {0.0, 10.0});
  p.motor.viscous_friction_Nms_per_rad = motor.number("viscous_friction_Nms_per_rad", {0.0, 10.0});
  p.motor.max_torque_Nm = motor.number("max_torque_Nm", {0.0, 50.0});
  motor.finish();
  p.agonist = read_muscle(plant.map("agonist"), control_period_s, supply_pressure_Pa);
  p.antagonist = read_muscle(plant.map("antagonist"), control_period_s, supply_pressure_Pa);
  plant.finish();
  return p;
}

OneDofRigBackend::OneDofRigBackend(const OneDofRigParams& params)
    : params_(params),
      model_(load_mjcf(params.model_file)),
      muscles_{{&params_.agonist, +1, Valve(params_.agonist.valve, params.timestep_s)},
               {&params_.antagonist, -1, Valve(params_.antagonist.valve, params.timestep_s)}},
      rng_(params.seed),
      push_start_angle_(params.finger.pushes.size(), std::numeric_limits<double>::quiet_NaN()) {
  const std::string name = params_.model_file.string();
  mjModel* m = model_.get();
  const int joint = require_id(m, mjOBJ_JOINT, "joint", name);
  dof_ = m->jnt_dofadr[joint];
  link_body_ = require_id(m, mjOBJ_BODY, "link", name);
  const int payload = require_id(m, mjOBJ_BODY, "payload", name);
  if (m->nv != 1) throw std::runtime_error(fmt::format("{}: expected 1 degree of freedom, found {}", name, m->nv));

  m->opt.timestep = params_.timestep_s;
  substeps_ = static_cast<int>(std::lround(params_.control_period_s / params_.timestep_s));
  // Payload: scale the weight's mass and inertia to the scenario's payload.
  const double scale = params_.payload_kg / m->body_mass[payload];
  m->body_mass[payload] = params_.payload_kg;
  for (int i = 0; i < 3; ++i) m->body_inertia[3 * payload + i] *= scale;
  // Motor: reflected rotor inertia and viscous friction belong to the joint.
  m->dof_armature[dof_] += params_.motor.rotor_inertia_kgm2 * params_.motor.gear_ratio * params_.motor.gear_ratio;
  base_damping_ = m->dof_damping[dof_] + params_.motor.viscous_friction_Nms_per_rad;
  base_frictionloss_ = m->dof_frictionloss[dof_] + params_.motor.coulomb_friction_Nm;

  data_.reset(mj_makeData(m));
  mj_setConst(m, data_.get());
  data_->qpos[m->jnt_qposadr[joint]] = params_.initial_angle_rad;
  mj_forward(m, data_.get());

  for (Muscle& mu : muscles_) {
    mu.valve.reset(mu.p->initial_pressure_Pa);
    // Twice: the first solve finds the contraction, the second starts from it at zero rate.
    solve_muscle(mu, params_.initial_angle_rad, params_.timestep_s);
    solve_muscle(mu, params_.initial_angle_rad, params_.timestep_s);
    // At rest the friction is static: the lowest tension along the wire is T*exp(-mu_s*psi).
    truth_.pulley_tension_min_N[mu.side > 0 ? 0 : 1] =
        mu.tension_N * std::exp(-mu.p->cable.static_friction * mu.p->cable.wrap_angle_rad);
  }
  info_.name = "sim:one_dof_rig";
  info_.joint_names = {"joint"};
  info_.period_s = params_.control_period_s;
  state_.joint_count = 1;
  sample();
}

void OneDofRigBackend::solve_muscle(Muscle& mu, double angle, double dt_s) noexcept {
  const MusclePlantParams& p = *mu.p;
  const double r0 = params_.pulley_radius_m;
  const double pressure = mu.valve.pressure_Pa();
  const double eps = p.contraction_at_zero_angle + mu.side * r0 * angle / p.rest_length_m;
  const double base = eps + (p.cable.initial_slack_m + mu.creep_m) / p.rest_length_m;
  const double per_N = 1.0 / (p.cable.wire_stiffness_N_per_m * p.rest_length_m);
  // Equilibrium of a massless muscle on an elastic wire: T = F(P, u(T), du/dt(T)) with
  // u(T) = base + T*per_N. The contraction rate is taken implicitly, (u(T) - u_previous)/dt: with an
  // explicit rate the hysteresis term chatters, because a stiff wire turns a small change of force
  // into a large change of rate. phi(T) = F - T decreases strictly in T (the static force falls with
  // u and the hysteresis factor falls with the rate), so the root is unique and bracketed by
  // [0, F at T = 0]. Newton steps with a difference quotient, bisection when a step leaves the bracket.
  const double u_previous = mu.contraction;
  auto phi = [&](double T) {
    const double u = base + T * per_N;
    return force_N(p.law, pressure, u, (u - u_previous) / dt_s) - T;
  };
  double lo = 0.0;
  double hi = phi(0.0);
  double T = 0.0;
  if (hi > 0.0) {
    T = std::clamp(mu.tension_N, lo, hi);
    for (int it = 0; it < 80; ++it) {
      const double r = phi(T);
      if (r > 0.0) lo = T; else hi = T;
      if (std::abs(r) < 1e-7 || hi - lo < 1e-9) break;
      const double h = 1e-6 * (1.0 + T);
      const double slope = (phi(T + h) - r) / h;
      double next = slope < 0.0 ? T - r / slope : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      T = next;
    }
  }
  const double u = base + T * per_N;
  mu.contraction = u;
  mu.tension_N = T;
}

double OneDofRigBackend::finger_force(double t, double angle, double omega) noexcept {
  const FingerParams& f = params_.finger;
  for (std::size_t i = 0; i < f.pushes.size(); ++i) {
    const FingerPush& push = f.pushes[i];
    if (t < push.start_s || t >= push.start_s + push.duration_s) continue;
    if (std::isnan(push_start_angle_[i])) push_start_angle_[i] = angle;
    const double start = push_start_angle_[i];
    const double goal = push.hold ? start : push.target_angle_rad;
    const double s = std::clamp((t - push.start_s) / push.move_s, 0.0, 1.0);
    const double blend = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);  // minimum jerk
    const double target = start + (goal - start) * blend;
    double force = f.stiffness_N_per_m * f.lever_m * (target - angle) - f.damping_Ns_per_m * f.lever_m * omega;
    force = std::clamp(force, -f.max_force_N, f.max_force_N);
    if (!push.hold) force = goal >= start ? std::max(force, 0.0) : std::min(force, 0.0);  // a finger only pushes
    truth_.finger_active = true;
    return force;
  }
  truth_.finger_active = false;
  return 0.0;
}

void OneDofRigBackend::substep(const io::JointCommand& cmd) noexcept {
  mjModel* m = model_.get();
  mjData* d = data_.get();
  const double dt = params_.timestep_s;
  const double angle = d->qpos[0];
  const double omega = d->qvel[dof_];
  const double r0 = params_.pulley_radius_m;

  muscles_[0].valve.step(cmd.agonist_pressure_Pa);
  muscles_[1].valve.step(cmd.antagonist_pressure_Pa);
  double friction_Nm = 0.0;
  for (Muscle& mu : muscles_) {
    solve_muscle(mu, angle, dt);
    const CablePlantParams& c = mu.p->cable;
    mu.creep_m = std::min(mu.creep_m + c.creep_m_per_N_s * mu.tension_N * dt, c.max_creep_m);
    // Capstan friction: the wire slides toward its muscle (v > 0) or away from it. Moving toward the
    // muscle the pulley end carries T*exp(-x); away, T*exp(+x). Around v = 0 the friction is static.
    const double v = mu.side * r0 * omega;
    const double mu_eff = c.kinetic_friction + (c.static_friction - c.kinetic_friction) *
                                                   std::exp(-(v / c.stribeck_velocity_mps) * (v / c.stribeck_velocity_mps));
    const double x = mu_eff * c.wrap_angle_rad;
    const double toward = mu.tension_N * (1.0 - std::exp(-x));
    const double away = mu.tension_N * (std::exp(x) - 1.0);
    const double weight = 0.5 * (1.0 + std::tanh(v / c.stribeck_velocity_mps));  // which way it slides
    friction_Nm += r0 * (weight * toward + (1.0 - weight) * away);
    truth_.pulley_tension_min_N[mu.side > 0 ? 0 : 1] = mu.tension_N * std::exp(-x);
  }
  const double motor = std::clamp(std::isfinite(cmd.motor_torque_Nm) ? cmd.motor_torque_Nm : 0.0,
                                  -params_.motor.max_torque_Nm, params_.motor.max_torque_Nm);
  m->dof_frictionloss[dof_] = base_frictionloss_ + friction_Nm;
  m->dof_damping[dof_] = base_damping_;

  mju_zero(d->qfrc_applied, m->nv);
  d->qfrc_applied[dof_] = r0 * (muscles_[0].tension_N - muscles_[1].tension_N) + motor;
  const double finger = finger_force(d->time, angle, omega);
  if (finger != 0.0) {
    const double c = std::cos(angle), s = std::sin(angle);
    const double* origin = d->xpos + 3 * link_body_;
    const double point[3] = {origin[0] + params_.finger.lever_m * c, origin[1], origin[2] + params_.finger.lever_m * s};
    const double force[3] = {-s * finger, 0.0, c * finger};  // along the link's upward normal
    const double torque[3] = {0.0, 0.0, 0.0};
    mj_applyFT(m, d, force, torque, point, link_body_, d->qfrc_applied);
  }
  mj_step(m, d);

  truth_.finger_force_N = finger;
  truth_.motor_torque_Nm = motor;
  truth_.cable_friction_Nm = friction_Nm;
  truth_.constraint_torque_Nm = d->qfrc_constraint[dof_];
}

double OneDofRigBackend::quantize(double value, double range) const noexcept {
  constexpr double kCodes = 65535.0;  // 16-bit AD
  const double code = std::round(std::clamp(value / range, 0.0, 1.0) * kCodes);
  return code / kCodes * range;
}

void OneDofRigBackend::sample() noexcept {
  const mjData* d = data_.get();
  const double angle = d->qpos[0];
  truth_.time_s = d->time;
  truth_.angle_rad = angle;
  truth_.velocity_radps = d->qvel[dof_];
  for (int i = 0; i < 2; ++i) {
    truth_.muscle_force_N[i] = muscles_[i].tension_N;
    truth_.pressure_Pa[i] = muscles_[i].valve.pressure_Pa();
    truth_.muscle_contraction[i] = muscles_[i].contraction;
    truth_.creep_m[i] = muscles_[i].creep_m;
  }
  const double counts_per_rad = params_.encoder_counts_per_rev / (2.0 * std::numbers::pi);
  io::JointSensors& s = state_.joints[0];
  s.angle_rad = std::floor(angle * counts_per_rad) / counts_per_rad;
  const double* force = truth_.muscle_force_N;
  s.agonist_force_N = quantize(force[0] + params_.agonist.loadcell_noise_N * unit_normal_(rng_), params_.agonist.loadcell_range_N);
  s.antagonist_force_N = quantize(force[1] + params_.antagonist.loadcell_noise_N * unit_normal_(rng_), params_.antagonist.loadcell_range_N);
  s.agonist_pressure_Pa = quantize(truth_.pressure_Pa[0] + params_.pressure_noise_Pa * unit_normal_(rng_), params_.pressure_range_Pa);
  s.antagonist_pressure_Pa = quantize(truth_.pressure_Pa[1] + params_.pressure_noise_Pa * unit_normal_(rng_), params_.pressure_range_Pa);
  state_.time_s = d->time;
  ++state_.sequence;
}

bool OneDofRigBackend::read(io::SensorState& state) noexcept {
  state = state_;
  return true;
}

bool OneDofRigBackend::write(const io::Command& command) noexcept {
  if (command.joint_count != 1) return false;
  for (int i = 0; i < substeps_; ++i) substep(command.joints[0]);
  sample();
  return true;
}

}  // namespace peha::sim
