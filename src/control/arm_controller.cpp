#include "peha/control/arm_controller.hpp"

namespace peha::control {

ArmController::ArmController(ArmControllerModel model)
    : model_(std::move(model)),
      data_(model_.arm),
      q_(Eigen::VectorXd::Zero(model_.arm.dof())),
      allocation_data_(model_.joints.size()),
      velocity_(model_.joints.size()),
      commanded_(model_.joints.size(), 0.0),
      diag_(model_.joints.size()) {
  for (auto& v : velocity_) v.cutoff_Hz = model_.velocity_cutoff_Hz;
}

void ArmController::update(const io::SensorState& state, io::Command& command) noexcept {
  const double dt_s = started_ ? state.time_s - last_time_s_ : 0.0;
  last_time_s_ = state.time_s;
  started_ = true;
  for (std::size_t i = 0; i < model_.joints.size(); ++i) q_[model_.joints[i].model_joint] = state.joints[i].angle_rad;
  const Eigen::VectorXd& tau_g = models::gravity_torque(model_.arm, data_, q_);

  command.joint_count = static_cast<int>(model_.joints.size());
  for (std::size_t i = 0; i < model_.joints.size(); ++i) {
    const ArmActuatedJoint& j = model_.joints[i];
    const io::JointSensors& s = state.joints[i];
    ArmJointDiagnostics& d = diag_[i];
    d.velocity_radps = velocity_[i].update(s.angle_rad, dt_s);
    d.torque_gravity_Nm = tau_g[j.model_joint];
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
