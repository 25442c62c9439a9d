#include "peha/control/arm_controller.hpp"

#include <cmath>

namespace peha::control {

ArmController::ArmController(ArmControllerModel model)
    : model_(std::move(model)),
      data_(model_.arm),
      q_(Eigen::VectorXd::Zero(model_.arm.dof())),
      allocation_data_(model_.joints.size()),
      velocity_(model_.joints.size()),
      commanded_(model_.joints.size(), 0.0),
      diag_(model_.joints.size()),
      tare_sum_N_(model_.joints.size(), {0.0, 0.0}) {
  for (auto& v : velocity_) v.cutoff_Hz = model_.velocity_cutoff_Hz;
  if (model_.allocation.loadcell_check.tare_s > 0.0) phase_ = StartupPhase::kVenting;
}

bool ArmController::startup(const io::SensorState& state, io::Command& command) noexcept {
  // As E1's controller (one_dof_gravity.cpp): the allocated joints' muscles vented (the limits layer
  // keeps them at the model's pretension pressure, below the muscles' threshold: no force), the motors
  // off, the operator holding the arm; then the load cells averaged and taken as their offsets.
  const LoadcellCheck& check = model_.allocation.loadcell_check;
  const double elapsed_s = state.time_s - phase_start_s_;
  if (phase_ == StartupPhase::kVenting && elapsed_s >= check.vent_s) {
    phase_ = StartupPhase::kTaring;
    phase_start_s_ = state.time_s;
  } else if (phase_ == StartupPhase::kTaring) {
    bool finite = true;
    for (std::size_t i = 0; i < model_.joints.size(); ++i) {
      finite = finite && std::isfinite(state.joints[i].agonist_loadcell_N) && std::isfinite(state.joints[i].antagonist_loadcell_N);
    }
    if (finite) {
      for (std::size_t i = 0; i < model_.joints.size(); ++i) {
        tare_sum_N_[i][0] += state.joints[i].agonist_loadcell_N;
        tare_sum_N_[i][1] += state.joints[i].antagonist_loadcell_N;
      }
      ++tare_samples_;
    }
    if (elapsed_s >= check.tare_s && tare_samples_ > 0) {
      for (std::size_t i = 0; i < model_.joints.size(); ++i) {
        if (model_.joints[i].mode == ArmJointMode::kHoldPressure) continue;  // not vented: nothing to tare
        for (int m = 0; m < 2; ++m) {
          const double offset_N = tare_sum_N_[i][static_cast<std::size_t>(m)] / static_cast<double>(tare_samples_);
          allocation_data_[i].loadcell_offset_N[m] = std::abs(offset_N) <= check.max_tare_N ? offset_N : 0.0;
        }
        allocation_data_[i].bumpless_start = false;  // the valves start from vented, the trim from 0
      }
      phase_ = StartupPhase::kCompensating;
      return false;
    }
  }
  command.joint_count = static_cast<int>(model_.joints.size());
  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    const ArmActuatedJoint& j = model_.joints[i];
    io::JointCommand& c = command.joints[i];
    diag_[i].allocation = AllocationOutput{};
    diag_[i].tau_desired_Nm = 0.0;
    const double hold = j.mode == ArmJointMode::kHoldPressure ? j.hold_pressure_Pa : 0.0;
    c.agonist_pressure_Pa = c.antagonist_pressure_Pa = hold;
    c.motor_torque_Nm = 0.0;
  }
  return true;
}

void ArmController::update(const io::SensorState& state, io::Command& command) noexcept {
  const double dt_s = started_ ? state.time_s - last_time_s_ : 0.0;
  last_time_s_ = state.time_s;
  if (!started_) phase_start_s_ = state.time_s;
  started_ = true;
  for (std::size_t i = 0; i < model_.joints.size(); ++i) q_[model_.joints[i].model_joint] = state.joints[i].angle_rad;
  const Eigen::VectorXd& tau_g = models::gravity_torque(model_.arm, data_, q_);

  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    diag_[i].velocity_radps = velocity_[i].update(state.joints[i].angle_rad, dt_s);
    diag_[i].torque_gravity_Nm = tau_g[model_.joints[i].model_joint];
  }
  if (phase_ != StartupPhase::kCompensating && startup(state, command)) return;
  if (compensating_since_s_ < 0.0) compensating_since_s_ = state.time_s;

  command.joint_count = static_cast<int>(model_.joints.size());
  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    const ArmActuatedJoint& j = model_.joints[i];
    const io::JointSensors& s = state.joints[i];
    ArmJointDiagnostics& d = diag_[i];
    io::JointCommand& c = command.joints[i];
    if (j.mode == ArmJointMode::kHoldPressure) {
      d.tau_desired_Nm = 0.0;
      c.agonist_pressure_Pa = c.antagonist_pressure_Pa = j.hold_pressure_Pa;
      c.motor_torque_Nm = 0.0;
      continue;
    }
    d.tau_desired_Nm = j.mode == ArmJointMode::kCommanded ? commanded_[i] : d.torque_gravity_Nm;
    AllocationInput in;
    in.tau_desired_Nm = d.tau_desired_Nm;
    in.angle_rad = s.angle_rad;
    in.velocity_radps = d.velocity_radps;
    in.agonist_loadcell_N = s.agonist_loadcell_N;
    in.antagonist_loadcell_N = s.antagonist_loadcell_N;
    in.agonist_pressure_Pa = s.agonist_pressure_Pa;
    in.antagonist_pressure_Pa = s.antagonist_pressure_Pa;
    in.dt_s = dt_s > 0.0 ? dt_s : model_.allocation.period_s;
    allocate(j.actuator, model_.allocation, allocation_data_[i], in, d.allocation);
    c.agonist_pressure_Pa = d.allocation.agonist_pressure_Pa;
    c.antagonist_pressure_Pa = d.allocation.antagonist_pressure_Pa;
    c.motor_torque_Nm = d.allocation.tau_motor_cmd_Nm;
  }
}

}  // namespace peha::control
