#include "peha/control/arm_controller.hpp"

#include "peha/control/joint_step.hpp"

namespace peha::control {

ArmController::ArmController(ArmControllerModel model)
    : model_(std::move(model)),
      data_(model_.arm),
      q_(Eigen::VectorXd::Zero(model_.arm.dof())),
      allocation_data_(model_.joints.size()),
      velocity_(model_.joints.size()),
      commanded_(model_.joints.size(), 0.0),
      diag_(model_.joints.size()),
      tare_(start_tare(model_.allocation.loadcell_check)) {
  for (auto& v : velocity_) v.cutoff_Hz = model_.velocity_cutoff_Hz;
  // Each load cell's zero from its muscle model until a start-up tare (if any) measures it.
  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    allocation_data_[i].loadcell_offset_N[0] = model_.joints[i].actuator.agonist.loadcell_zero_N;
    allocation_data_[i].loadcell_offset_N[1] = model_.joints[i].actuator.antagonist.loadcell_zero_N;
  }
}

void ArmController::update(const io::SensorState& state, io::Command& command) noexcept {
  const double dt_s = started_ ? state.time_s - last_time_s_ : 0.0;
  last_time_s_ = state.time_s;
  started_ = true;
  for (std::size_t i = 0; i < model_.joints.size(); ++i) q_[model_.joints[i].model_joint] = state.joints[i].angle_rad;
  const Eigen::VectorXd& tau_g = models::gravity_torque(model_.arm, data_, q_);

  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    diag_[i].velocity_radps = velocity_[i].update(state.joints[i].angle_rad, dt_s);
    diag_[i].torque_gravity_Nm = tau_g[model_.joints[i].model_joint];
  }
  // Start-up tare (control/startup_tare.hpp), as E1's controller: the allocated joints vented (the
  // hold-pressure joints keep their pressure), the motors off, the operator holding the arm; then
  // each allocated joint's load-cell offsets subtracted and its trim started from 0.
  const LoadcellCheck& check = model_.allocation.loadcell_check;
  const bool was_starting = tare_.phase != StartupPhase::kCompensating;
  if (step_startup_tare(check, state, tare_)) {
    command.joint_count = static_cast<int>(model_.joints.size());
    for (std::size_t i = 0; i < model_.joints.size(); ++i) {
      const ArmActuatedJoint& j = model_.joints[i];
      const double hold = j.mode == ArmJointMode::kHoldPressure ? j.hold_pressure_Pa : 0.0;
      diag_[i].allocation = AllocationOutput{};
      diag_[i].tau_desired_Nm = 0.0;
      command.joints[i] = {hold, hold, 0.0, declared_zero(allocation_data_[i])};
    }
    return;
  }
  if (was_starting) {
    for (std::size_t i = 0; i < model_.joints.size(); ++i) {
      if (model_.joints[i].mode == ArmJointMode::kHoldPressure) continue;  // not vented: nothing to tare
      for (int m = 0; m < 2; ++m) allocation_data_[i].loadcell_offset_N[m] = tare_offset_N(check, tare_, static_cast<int>(i), m);
      allocation_data_[i].bumpless_start = false;  // the valves start from vented, the trim from 0
    }
  }

  command.joint_count = static_cast<int>(model_.joints.size());
  const bool slack = wires_slack_on_purpose(state.time_s);
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
    JointStepInput step;
    step.tau_desired_Nm = d.tau_desired_Nm;
    step.velocity_radps = d.velocity_radps;
    step.time_s = state.time_s;
    step.dt_s = dt_s > 0.0 ? dt_s : model_.allocation.period_s;
    step.after_startup = was_starting;
    step.tension_expected = !slack;
    step_joint(j.actuator, model_.allocation, model_.creep, s, step, allocation_data_[i], d.creep, d.allocation_input, d.allocation);
    c.agonist_pressure_Pa = d.allocation.agonist_pressure_Pa;
    c.antagonist_pressure_Pa = d.allocation.antagonist_pressure_Pa;
    c.motor_torque_Nm = d.allocation.tau_motor_cmd_Nm;
  }
  for (std::size_t i = 0; i < model_.joints.size(); ++i) command.joints[i].loadcell_zero_N = declared_zero(allocation_data_[i]);
}

}  // namespace peha::control
