#include "peha/sim/arm_plant.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace peha::sim {
namespace {

/// The plant's bodies with `unknown_kg` added to every hand's payload body ("payload", or "R_payload"
/// and "L_payload" on a body with both arms): still a steel sphere at the hand's centre of mass (as
/// models::build_arm_model makes it), so its inertia grows as m^(5/3).
models::ArmModel with_unknown_payload(models::ArmModel model, double unknown_kg) {
  if (unknown_kg == 0.0) return model;
  int payloads = 0;
  for (models::ArmBody& payload : model.bodies) {
    if (payload.name != "payload" && !payload.name.ends_with("_payload")) continue;
    ++payloads;
    const double mass_kg = payload.mass_kg + unknown_kg;
    if (!(mass_kg >= 0.0)) {
      throw std::invalid_argument(fmt::format("arm plant: {} {} kg + unknown hand payload {} kg is negative", payload.name,
                                              payload.mass_kg, unknown_kg));
    }
    constexpr double kSteelDensity_kg_per_m3 = 7850.0;
    const double radius_m = std::cbrt(3.0 * mass_kg / (4.0 * std::numbers::pi * kSteelDensity_kg_per_m3));
    payload.mass_kg = mass_kg;
    payload.inertia_kgm2 = Eigen::Matrix3d::Identity() * (0.4 * mass_kg * radius_m * radius_m);
  }
  if (payloads == 0) throw std::invalid_argument("arm plant: an unknown hand payload needs a hand payload body (\"payload\" or \"<side>_payload\")");
  return model;
}

}  // namespace

ArmBackend::ArmBackend(const ArmPlantParams& params)
    : params_(params),
      model_(load_arm_mjcf(arm_mjcf(with_unknown_payload(params.model, params.unknown_hand_payload_kg), params.mjcf))),
      rng_(params.seed),
      gate_(params.control_period_s, kSafeVent_s),
      fault_applied_(params.faults.size(), 0),
      encoder_offset_rad_(params.actuated.size(), 0.0),
      encoder_frozen_(params.actuated.size(), 0) {
  mjModel* m = model_.get();
  if (params_.actuated.size() != params_.actuators.size() || params_.actuated.size() > io::kMaxJoints) {
    throw std::invalid_argument("arm plant: one actuator per actuated joint, at most io::kMaxJoints");
  }
  for (const PlantFault& f : params_.faults) {
    if (f.joint < 0 || static_cast<std::size_t>(f.joint) >= params_.actuated.size()) {
      throw std::invalid_argument(fmt::format("arm plant: fault {} targets actuated joint {}, the arm has {}",
                                              fault_kind_name(f.kind), f.joint, params_.actuated.size()));
    }
  }
  if (static_cast<int>(params_.initial_q_rad.size()) != m->nq) {
    throw std::invalid_argument(fmt::format("arm plant: initial_q has {} values, the model {} joints",
                                            params_.initial_q_rad.size(), m->nq));
  }
  m->opt.timestep = params_.timestep_s;
  substeps_ = static_cast<int>(std::lround(params_.control_period_s / params_.timestep_s));
  data_.reset(mj_makeData(m));
  for (int i = 0; i < m->nq; ++i) data_->qpos[i] = params_.initial_q_rad[static_cast<std::size_t>(i)];
  for (std::size_t a = 0; a < params_.actuated.size(); ++a) {
    const int joint = require_id(m, mjOBJ_JOINT, params_.actuated[a], "arm plant");
    const int dof = m->jnt_dofadr[joint];
    dof_.push_back(dof);
    joints_.emplace_back(params_.actuators[a], params_.timestep_s, data_->qpos[m->jnt_qposadr[joint]]);
    m->dof_armature[dof] += joints_.back().armature_kgm2();
    base_damping_.push_back(m->dof_damping[dof] + joints_.back().viscous_friction_Nms_per_rad());
    base_frictionloss_.push_back(m->dof_frictionloss[dof] + joints_.back().coulomb_friction_Nm());
    info_.joint_names.push_back(params_.actuated[a]);
  }
  mj_setConst(m, data_.get());
  // mj_setConst works at qpos0 and leaves qpos there: the initial posture goes in afterwards.
  for (int i = 0; i < m->nq; ++i) data_->qpos[i] = params_.initial_q_rad[static_cast<std::size_t>(i)];
  mj_forward(m, data_.get());
  move_start_.assign(params_.actuated.size(), 0.0);
  truth_.q_rad.resize(static_cast<std::size_t>(m->nq));
  truth_.qd_radps.resize(static_cast<std::size_t>(m->nv));
  truth_.operator_torque_Nm.assign(params_.actuated.size(), 0.0);
  truth_.actuator_torque_Nm.assign(params_.actuated.size(), 0.0);
  truth_.constraint_torque_Nm.assign(params_.actuated.size(), 0.0);
  truth_.bias_torque_Nm.assign(params_.actuated.size(), 0.0);
  truth_.actuated_q_rad.assign(params_.actuated.size(), 0.0);
  truth_.actuators.resize(params_.actuated.size());
  info_.name = "sim:arm";
  info_.period_s = params_.control_period_s;
  state_.joint_count = static_cast<int>(params_.actuated.size());
  settle();
  sample();
  sampled_truth_ = truth_;
}

void ArmBackend::substep(const io::Command& command) noexcept {
  mjModel* m = model_.get();
  mjData* d = data_.get();
  mju_zero(d->qfrc_applied, m->nv);

  // The operator's hands: which move is on, and its minimum-jerk target per joint.
  const double t = d->time;
  int move = -1;
  for (std::size_t k = 0; k < params_.operator_hands.moves.size(); ++k) {
    const OperatorMove& mv = params_.operator_hands.moves[k];
    // Before t = 0 the hands of a move that starts at 0 already hold its posture (the person's own arm).
    if (settling_ ? mv.start_s <= 0.0 : t >= mv.start_s && t < mv.start_s + mv.duration_s) move = static_cast<int>(k);
  }
  if (kept_move_ >= 0) move = kept_move_;
  if (move != active_move_ && move >= 0) {
    for (std::size_t a = 0; a < dof_.size(); ++a) move_start_[a] = d->qpos[m->jnt_qposadr[m->dof_jntid[dof_[a]]]];
  }
  active_move_ = move;
  truth_.operator_active = move >= 0;

  for (std::size_t a = 0; a < joints_.size(); ++a) {
    const int dof = dof_[a];
    const double angle = d->qpos[m->jnt_qposadr[m->dof_jntid[dof]]];
    const double omega = d->qvel[dof];
    const PehaJointPlant::Forces f = joints_[a].step(command.joints[a], angle, omega);
    m->dof_frictionloss[dof] = base_frictionloss_[a] + f.friction_bound_Nm;
    m->dof_damping[dof] = base_damping_[a];
    d->qfrc_applied[dof] += f.torque_Nm;
    truth_.actuator_torque_Nm[a] = f.torque_Nm;
    double hands = 0.0;
    if (move >= 0) {
      const OperatorMove& mv = params_.operator_hands.moves[static_cast<std::size_t>(move)];
      const double goal = mv.target_rad[a];
      if (std::isfinite(goal)) {
        const double blend = settling_ ? 1.0 : minimum_jerk((t - mv.start_s) / mv.move_s);
        const double target = move_start_[a] + (goal - move_start_[a]) * blend;
        const OperatorParams& op = params_.operator_hands;
        hands = std::clamp(op.stiffness_Nm_per_rad * (target - angle) - op.damping_Nms_per_rad * omega,
                           -op.max_torque_Nm, op.max_torque_Nm);
      }
    }
    d->qfrc_applied[dof] += hands;
    truth_.operator_torque_Nm[a] = hands;
  }
  mj_step(m, d);
}

void ArmBackend::settle() {
  if (params_.settle_s < 0.0) throw std::invalid_argument("arm plant: settle_s must be >= 0");
  settling_ = true;
  for (PehaJointPlant& j : joints_) j.faults().dump = true;
  io::Command vented;
  vented.joint_count = static_cast<int>(joints_.size());
  const auto steps = static_cast<long>(std::llround(params_.settle_s / params_.timestep_s));
  for (long k = 0; k < steps; ++k) substep(vented);
  settling_ = false;
  active_move_ = -1;  // at t = 0 the first move grips the arm where it rests
  data_->time = 0.0;
}

void ArmBackend::sample() noexcept {
  const mjModel* m = model_.get();
  const mjData* d = data_.get();
  truth_.time_s = d->time;
  for (int i = 0; i < m->nq; ++i) truth_.q_rad[static_cast<std::size_t>(i)] = d->qpos[i];
  for (int i = 0; i < m->nv; ++i) truth_.qd_radps[static_cast<std::size_t>(i)] = d->qvel[i];
  for (std::size_t a = 0; a < joints_.size(); ++a) {
    truth_.actuators[a] = joints_[a].truth();
    const int dof = dof_[a];
    truth_.constraint_torque_Nm[a] = d->qfrc_constraint[dof];
    truth_.bias_torque_Nm[a] = d->qfrc_bias[dof];
    io::JointSensors& s = state_.joints[a];
    const double angle = d->qpos[m->jnt_qposadr[m->dof_jntid[dof_[a]]]];
    truth_.actuated_q_rad[a] = angle;
    if (!encoder_frozen_[a]) s.angle_rad = encoder_angle_rad(angle + encoder_offset_rad_[a], params_.encoder_counts_per_rev);
    s.redundant_angle_rad = redundant_encoder_angle_rad(angle, params_.joint_encoder_counts_per_rev);
    joints_[a].sense(params_.pressure_noise_Pa, params_.pressure_range_Pa, rng_, s);
  }
  state_.time_s = d->time;
  ++state_.sequence;
}

bool ArmBackend::read(io::SensorState& state) noexcept {
  if (!gate_.samples()) return false;  // an outage (OutputGate): the host hears nothing
  state = state_;
  sampled_truth_ = truth_;  // same sizes every time: no allocation after the constructor's copy
  return true;
}

void ArmBackend::apply_faults(double t_s) noexcept {
  for (PehaJointPlant& j : joints_) advance_joint_faults(t_s, j.faults());
  for (std::size_t i = 0; i < params_.faults.size(); ++i) {
    const PlantFault& f = params_.faults[i];
    if (fault_applied_[i] || t_s + 1e-9 < f.time_s) continue;
    fault_applied_[i] = 1;
    const auto a = static_cast<std::size_t>(f.joint);
    switch (f.kind) {
      case FaultKind::kSupplyZero:
      case FaultKind::kSupplyHalf:
        for (PehaJointPlant& j : joints_) apply_joint_fault(f, j.faults());  // one supply feeds every joint
        break;
      case FaultKind::kEncoderJump: encoder_offset_rad_[a] += models::deg_to_rad(f.value); break;
      case FaultKind::kEncoderFrozen: encoder_frozen_[a] = 1; break;
      case FaultKind::kEstop: gate_.estop(); break;
      case FaultKind::kStateLoss: gate_.lose_samples(f.value); break;
      case FaultKind::kBoardReboot: gate_.reboot(f.value); break;
      default: apply_joint_fault(f, joints_[a].faults()); break;
    }
  }
}

bool ArmBackend::write(const io::Command& command) noexcept {
  if (command.joint_count != static_cast<int>(joints_.size())) return false;
  apply_faults(data_->time);
  // Vented (not active): the board's dump valves empty the chambers past a stuck valve.
  for (PehaJointPlant& j : joints_) j.faults().dump = !gate_.status().active;
  const io::Command& applied = gate_.apply(command);
  for (int i = 0; i < substeps_; ++i) substep(applied);
  sample();
  return true;
}

}  // namespace peha::sim
