#pragma once
/// \file
/// Torque control of the right arm (docs/right-arm.md): gravity compensation tau = J^T G of the robot and
/// the user's arm from the controller's own nominal model (feed-forward only, no position
/// feedback), turned into pressures and motor torques joint by joint by the macro-mini allocation.
/// A joint may instead be driven by a desired torque the experiment supplies each cycle (E4's
/// inverse dynamics, E6's chirp) or held at a constant pressure in both muscles (the wrist).

#include "peha/control/allocation.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/arm.hpp"
#include "peha/models/joint.hpp"

#include <vector>

namespace peha::control {

enum class ArmJointMode {
  kGravity,        ///< desired torque = the J^T G component of this joint
  kCommanded,      ///< desired torque = the value set by set_desired_torque()
  kHoldPressure,   ///< both muscles at hold_pressure_Pa, no torque control (compliant hold)
};

struct ArmActuatedJoint {
  int model_joint = 0;          ///< index into ArmModel::joints
  models::JointModel actuator;  ///< the controller's PAM/Bowden/motor model of this joint
  ArmJointMode mode = ArmJointMode::kGravity;
  double hold_pressure_Pa = 0.25e6;
};

struct ArmControllerModel {
  models::ArmModel arm;                 ///< nominal rigid bodies (exo + user arm + payload)
  std::vector<ArmActuatedJoint> joints; ///< io joint i = joints[i]
  AllocationParams allocation;
  /// Online tracking of wire creep and slack on every allocated joint (wire_creep_estimator.hpp;
  /// off by default), as E1's controller: the same joint step (joint_step.hpp).
  CreepEstimatorParams creep;
  double velocity_cutoff_Hz = 20.0;
};

/// Per actuated joint, what the last step computed (logs and plots).
struct ArmJointDiagnostics {
  double velocity_radps = 0;
  double torque_gravity_Nm = 0;  ///< J^T G component
  double tau_desired_Nm = 0;
  AllocationInput allocation_input;  ///< what the allocation was given
  AllocationOutput allocation;
  CreepEstimatorData creep;          ///< the creep estimator's state after this step (ArmControllerModel::creep)
};

class ArmController {
 public:
  explicit ArmController(ArmControllerModel model);
  /// One control step; noexcept and allocation-free. Unactuated joints are taken at 0 (clamped).
  void update(const io::SensorState& state, io::Command& command) noexcept;
  /// Desired torque of io joint `joint` in kCommanded mode, Nm.
  void set_desired_torque(int joint, double torque_Nm) noexcept { commanded_[static_cast<std::size_t>(joint)] = torque_Nm; }
  void set_mode(int joint, ArmJointMode mode) noexcept { model_.joints[static_cast<std::size_t>(joint)].mode = mode; }
  const std::vector<ArmJointDiagnostics>& diagnostics() const { return diag_; }
  const ArmControllerModel& model() const { return model_; }

  /// The start-up (AllocationParams::loadcell_check.tare_s > 0), as E1's controller has it: every
  /// allocated joint vented for vent_s (hold-pressure joints keep their pressure), their load cells
  /// averaged over tare_s and subtracted from then on, then compensation (trims from 0).
  StartupPhase startup_phase() const noexcept { return tare_.phase; }
  /// When compensation began, s (< 0 before); the wires are slack on purpose until refill_s later.
  double compensating_since_s() const noexcept { return tare_.compensating_since_s; }
  /// True while the wires are slack on purpose (vent, tare and refill_s after): tension not judged.
  bool wires_slack_on_purpose(double t_s) const noexcept {
    return control::wires_slack_on_purpose(model_.allocation.loadcell_check, tare_, t_s);
  }
  /// The operator's recovery after a fault: every allocated joint's next step starts from its measured
  /// pressures (control::resume_allocation), not from what it integrated while its commands did not
  /// go out. noexcept.
  void resume() noexcept {
    for (AllocationData& a : allocation_data_) resume_allocation(a);
  }
  /// The tare of allocated joint i (agonist, antagonist), N; 0 before it is done.
  double loadcell_offset_N(std::size_t joint, int muscle) const noexcept {
    return allocation_data_[joint].loadcell_offset_N[muscle];
  }

 private:

  ArmControllerModel model_;
  models::ArmData data_;
  Eigen::VectorXd q_;
  std::vector<AllocationData> allocation_data_;
  std::vector<VelocityEstimator> velocity_;
  std::vector<double> commanded_;
  std::vector<ArmJointDiagnostics> diag_;
  double last_time_s_ = 0;
  bool started_ = false;
  StartupTare tare_;
};

}  // namespace peha::control
