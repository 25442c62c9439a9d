#pragma once
/// \file
/// One joint's control step after the start-up tare, shared by every controller (E1's one-DOF
/// controller, the arm controller and through it a user's own): the wire-creep estimator when it is
/// on (control/wire_creep_estimator.hpp: its correction of each muscle's contraction shapes this
/// step's command), then the macro-mini allocation of the desired torque to the muscle pair and the
/// motor (control/allocation.hpp). Model/Data: the joint's models are constant, the state is the
/// caller's. noexcept and allocation-free.

#include "peha/control/allocation.hpp"
#include "peha/control/wire_creep_estimator.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"

namespace peha::control {

/// What one step of one joint reads besides its sensors.
struct JointStepInput {
  double tau_desired_Nm = 0;
  double velocity_radps = 0;
  double time_s = 0;
  double dt_s = 1e-3;             ///< since the previous step (the allocation period on the first)
  bool after_startup = false;     ///< the first step after the start-up tare: no previous command yet
  bool tension_expected = true;   ///< false while the wires are slack on purpose
};

/// One step of the joint `joint` with sensors `s`: the creep estimator (if `creep.enabled`), then
/// the allocation into `out` (whose previous values are the creep estimator's last command).
/// `in` is the allocation's input as built here (kept for the diagnostics).
void step_joint(const models::JointModel& joint, const AllocationParams& allocation, const CreepEstimatorParams& creep,
                const io::JointSensors& s, const JointStepInput& step, AllocationData& data, CreepEstimatorData& creep_data,
                AllocationInput& in, AllocationOutput& out) noexcept;

}  // namespace peha::control
