#include "peha/sim/one_dof_rig.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace peha::sim {
namespace {

}  // namespace

OneDofRigParams read_one_dof_rig(config::Map& plant, double control_period_s, double supply_pressure_Pa) {
  OneDofRigParams p;
  p.control_period_s = control_period_s;
  p.supply_pressure_Pa = supply_pressure_Pa;
  p.model_file = plant.path_value("model");
  p.timestep_s = read_timestep_s(plant, control_period_s);
  config::Map pressure = plant.map("pressure_sensor");
  p.pressure_noise_Pa = pressure.number("noise_MPa", {0.0, 0.1}) * 1e6;
  p.pressure_range_Pa = pressure.number("range_MPa", {0.1, 2.0}) * 1e6;
  pressure.finish();
  p.encoder_counts_per_rev = plant.number("encoder_counts_per_rev", {16, 1e9});
  p.joint_encoder_counts_per_rev = plant.number_or("joint_encoder_counts_per_rev", 0.0, {0, 1e9});
  p.unknown_payload_kg = plant.number_or("unknown_payload_kg", 0.0, {-20.0, 20.0});
  p.joint = read_peha_joint_plant(plant, supply_pressure_Pa, /*has_motor=*/true);
  plant.finish();
  return p;
}

const std::vector<std::string>& one_dof_rig_joint_names() {
  static const std::vector<std::string> names = {"joint"};
  return names;
}

OneDofRigBackend::OneDofRigBackend(const OneDofRigParams& params)
    : params_(params),
      model_(load_mjcf(params.model_file)),
      joint_(params_.joint, params.timestep_s, params.initial_angle_rad),
      rng_(params.seed),
      push_start_angle_(params.finger.pushes.size(), std::numeric_limits<double>::quiet_NaN()),
      gate_(params.control_period_s, kSafeVent_s),
      fault_applied_(params.faults.size(), 0) {
  const std::string name = params_.model_file.string();
  mjModel* m = model_.get();
  const int joint = require_id(m, mjOBJ_JOINT, "joint", name);
  dof_ = m->jnt_dofadr[joint];
  link_body_ = require_id(m, mjOBJ_BODY, "link", name);
  const int payload = require_id(m, mjOBJ_BODY, "payload", name);
  if (m->nv != 1) throw std::runtime_error(fmt::format("{}: expected 1 degree of freedom, found {}", name, m->nv));

  m->opt.timestep = params_.timestep_s;
  substeps_ = static_cast<int>(std::lround(params_.control_period_s / params_.timestep_s));
  // Payload: scale the weight's mass and inertia to the scenario's payload plus the unknown one.
  const double payload_kg = params_.payload_kg + params_.unknown_payload_kg;
  if (!(payload_kg >= 0.0)) {
    throw std::invalid_argument(fmt::format("{}: payload {} kg + unknown payload {} kg is negative", name,
                                            params_.payload_kg, params_.unknown_payload_kg));
  }
  const double scale = payload_kg / m->body_mass[payload];
  m->body_mass[payload] = payload_kg;
  for (int i = 0; i < 3; ++i) m->body_inertia[3 * payload + i] *= scale;
  // Motor: reflected rotor inertia and viscous friction belong to the joint.
  m->dof_armature[dof_] += joint_.armature_kgm2();
  base_damping_ = m->dof_damping[dof_] + joint_.viscous_friction_Nms_per_rad();
  base_frictionloss_ = m->dof_frictionloss[dof_] + joint_.coulomb_friction_Nm();

  // A joint clamp (E5's locked rig): an equality constraint named "lock" on the joint holds it at
  // the initial angle (MuJoCo's joint equality q - qpos0 = polycoef[0]; qpos0 is 0 for this hinge).
  const int lock = mj_name2id(m, mjOBJ_EQUALITY, "lock");
  if (lock >= 0) {
    if (m->eq_type[lock] != mjEQ_JOINT || m->eq_obj1id[lock] != joint || m->eq_obj2id[lock] >= 0 || m->qpos0[m->jnt_qposadr[joint]] != 0.0) {
      throw std::runtime_error(fmt::format("{}: equality 'lock' must be a joint equality on 'joint' alone, with the joint's reference at 0", name));
    }
    m->eq_data[mjNEQDATA * lock] = params_.initial_angle_rad;
  }

  data_.reset(mj_makeData(m));
  mj_setConst(m, data_.get());
  data_->qpos[m->jnt_qposadr[joint]] = params_.initial_angle_rad;
  mj_forward(m, data_.get());

  info_.name = "sim:one_dof_rig";
  info_.joint_names = one_dof_rig_joint_names();
  info_.period_s = params_.control_period_s;
  state_.joint_count = 1;
  sample();
  sampled_truth_ = truth_;
}

double OneDofRigBackend::finger_force(double t, double angle, double omega) noexcept {
  const FingerParams& f = params_.finger;
  for (std::size_t i = 0; i < f.pushes.size(); ++i) {
    const FingerPush& push = f.pushes[i];
    const bool kept = static_cast<int>(i) == kept_support_;
    if (t < push.start_s || (t >= push.start_s + push.duration_s && !kept)) continue;
    active_support_ = push.support_stiffness_N_per_m > 0 ? static_cast<int>(i) : -1;
    if (std::isnan(push_start_angle_[i])) push_start_angle_[i] = angle;
    const double start = push_start_angle_[i];
    const double goal = push.hold ? start : push.target_angle_rad;
    const double blend = minimum_jerk((t - push.start_s) / push.move_s);
    const double target = start + (goal - start) * blend;
    const bool support = push.support_stiffness_N_per_m > 0;
    const double k = support ? push.support_stiffness_N_per_m : f.stiffness_N_per_m;
    const double c = support ? push.support_damping_Ns_per_m : f.damping_Ns_per_m;
    const double max_N = support ? push.support_max_force_N : f.max_force_N;
    double force = k * f.lever_m * (target - angle) - c * f.lever_m * omega;
    force = std::clamp(force, -max_N, max_N);
    if (!push.hold && !push.clamp) force = goal >= start ? std::max(force, 0.0) : std::min(force, 0.0);  // a finger only pushes
    truth_.finger_active = true;
    return force;
  }
  truth_.finger_active = false;
  active_support_ = -1;
  return 0.0;
}

void OneDofRigBackend::substep(const io::JointCommand& cmd) noexcept {
  mjModel* m = model_.get();
  mjData* d = data_.get();
  const double angle = d->qpos[0];
  const double omega = d->qvel[dof_];

  const PehaJointPlant::Forces forces = joint_.step(cmd, angle, omega);
  m->dof_frictionloss[dof_] = base_frictionloss_ + forces.friction_bound_Nm;
  m->dof_damping[dof_] = base_damping_;

  mju_zero(d->qfrc_applied, m->nv);
  d->qfrc_applied[dof_] = forces.torque_Nm;
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
  truth_.constraint_torque_Nm = d->qfrc_constraint[dof_];
}

void OneDofRigBackend::sample() noexcept {
  const mjData* d = data_.get();
  const double angle = d->qpos[0];
  truth_.time_s = d->time;
  truth_.angle_rad = angle;
  truth_.velocity_radps = d->qvel[dof_];
  static_cast<PehaJointTruth&>(truth_) = joint_.truth();
  io::JointSensors& s = state_.joints[0];
  if (!encoder_frozen_) s.angle_rad = encoder_angle_rad(angle + encoder_offset_rad_, params_.encoder_counts_per_rev);
  s.redundant_angle_rad = redundant_encoder_angle_rad(angle, params_.joint_encoder_counts_per_rev);
  joint_.sense(params_.pressure_noise_Pa, params_.pressure_range_Pa, rng_, s);
  state_.time_s = d->time;
  ++state_.sequence;
}

bool OneDofRigBackend::read(io::SensorState& state) noexcept {
  if (!gate_.samples()) return false;  // an outage (OutputGate): the host hears nothing
  state = state_;
  sampled_truth_ = truth_;
  return true;
}

void OneDofRigBackend::apply_faults(double t_s) noexcept {
  advance_joint_faults(t_s, joint_.faults());
  for (std::size_t i = 0; i < params_.faults.size(); ++i) {
    const PlantFault& f = params_.faults[i];
    if (fault_applied_[i] || t_s + 1e-9 < f.time_s) continue;
    fault_applied_[i] = 1;
    apply_joint_fault(f, joint_.faults());
    switch (f.kind) {
      case FaultKind::kEncoderJump: encoder_offset_rad_ += models::deg_to_rad(f.value); break;
      case FaultKind::kEncoderFrozen: encoder_frozen_ = true; break;
      case FaultKind::kEstop: gate_.estop(); break;
      case FaultKind::kStateLoss: gate_.lose_samples(f.value); break;
      case FaultKind::kBoardReboot: gate_.reboot(f.value); break;
      default: break;
    }
  }
}

bool OneDofRigBackend::write(const io::Command& command) noexcept {
  if (command.joint_count != 1) return false;
  apply_faults(data_->time);
  joint_.faults().dump = !gate_.status().active;
  const io::Command& applied = gate_.apply(command);
  for (int i = 0; i < substeps_; ++i) substep(applied.joints[0]);
  sample();
  return true;
}

}  // namespace peha::sim
