#include "peha/control/allocation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace peha::control {
namespace {

struct MuscleCommand {
  double force_N;
  double pressure_Pa;
  double contraction;
  bool clamped;
  bool saturated;
};

/// `wire_velocity_mps`: this muscle's wire velocity (> 0 toward the muscle).
MuscleCommand command_muscle(const models::JointModel& joint, const models::MuscleModel& m, int side, double joint_force_N,
                             double wire_velocity_mps, const AllocationParams& params, const AllocationInput& in, double loadcell_N,
                             double measured_pressure_Pa, bool first, bool sensors_valid, double& trim_N) {
  const double supply_Pa = joint.supply_pressure_Pa;
  const double wanted = models::muscle_force_for_joint_N(m.bowden, joint_force_N, wire_velocity_mps);
  const double ceiling = models::force_ceiling_N(m);
  const double force = std::clamp(wanted, std::min(joint.pretension_N, ceiling), ceiling);
  const double eps = models::rigid_contraction(m, joint.pulley_radius_m, side, in.angle_rad);
  if (params.force_trim_rate_1ps > 0.0 && sensors_valid && first && std::isfinite(measured_pressure_Pa)) {
    const double held_N = models::forward_force_N(m.pam, measured_pressure_Pa, eps);  // what the model says P makes
    trim_N = std::clamp(held_N - force, -params.force_trim_max_N, params.force_trim_max_N);
  } else if (params.force_trim_rate_1ps > 0.0 && sensors_valid) {
    const double step = params.force_trim_rate_1ps * (force - loadcell_N) * in.dt_s;
    const auto now = models::muscle_pressure(m, force + trim_N, eps, supply_Pa);
    // Anti-windup: do not integrate further into a saturated pressure.
    const bool at_top = now.pressure_Pa >= supply_Pa && step > 0.0;
    const bool at_bottom = now.pressure_Pa <= 0.0 && step < 0.0;
    if (!at_top && !at_bottom) trim_N = std::clamp(trim_N + step, -params.force_trim_max_N, params.force_trim_max_N);
  }
  const auto inv = models::muscle_pressure(m, force + trim_N, eps, supply_Pa);
  return {force, inv.pressure_Pa, eps, wanted > ceiling,
          inv.status == models::InverseStatus::kSaturated || inv.status == models::InverseStatus::kUnreachable};
}

bool finite(const AllocationInput& in) {
  return std::isfinite(in.tau_desired_Nm) && std::isfinite(in.angle_rad) &&
         std::isfinite(in.velocity_radps) && std::isfinite(in.agonist_loadcell_N) &&
         std::isfinite(in.antagonist_loadcell_N) && std::isfinite(in.dt_s) && in.dt_s > 0.0;
}

}  // namespace

AllocationParams read_allocation(config::Map map, double& pretension_N) {
  AllocationParams p;
  p.pam_cutoff_Hz = map.number("pam_cutoff_Hz", {0.01, 500.0});
  pretension_N = map.number("pretension_N", {1.0, 500.0});
  p.use_motor = map.boolean("use_motor");
  p.force_trim_rate_1ps = map.number("force_trim_rate_1ps", {0.0, 100.0});
  p.force_trim_max_N = map.number("force_trim_max_N", {0.0, 2000.0});
  map.finish();
  return p;
}

void allocate(const models::JointModel& joint, const AllocationParams& params, AllocationData& data,
              const AllocationInput& raw, AllocationOutput& out) noexcept {
  out.flags = 0;
  AllocationInput in = raw;
  if (!finite(in)) {
    // Keep the last PAM share (no jump), estimate nothing from bad sensors, motor off.
    out.flags |= kNonFiniteInput;
    in.tau_desired_Nm = data.tau_pam_filtered_Nm;
    in.velocity_radps = 0.0;
    in.agonist_loadcell_N = in.antagonist_loadcell_N = 0.0;
    if (!std::isfinite(in.angle_rad)) in.angle_rad = 0.0;
    if (!(std::isfinite(in.dt_s) && in.dt_s > 0.0)) in.dt_s = params.period_s;
  }
  const double r0 = joint.pulley_radius_m;

  // Macro: first-order low-pass of the desired torque (exact discretisation).
  const bool first = !data.initialized;
  if (first) {
    data.tau_pam_filtered_Nm = in.tau_desired_Nm;
    data.initialized = true;
  }
  const double blend = 1.0 - std::exp(-2.0 * std::numbers::pi * params.pam_cutoff_Hz * in.dt_s);
  data.tau_pam_filtered_Nm += blend * (in.tau_desired_Nm - data.tau_pam_filtered_Nm);
  out.tau_pam_cmd_Nm = data.tau_pam_filtered_Nm;

  // Pulley forces: the pretension on both wires, plus the torque on the side that can make it.
  const double pull_N = std::abs(out.tau_pam_cmd_Nm) / r0;
  const double agonist_joint_force_cmd_N = joint.pretension_N + (out.tau_pam_cmd_Nm >= 0.0 ? pull_N : 0.0);
  const double antagonist_joint_force_cmd_N = joint.pretension_N + (out.tau_pam_cmd_Nm < 0.0 ? pull_N : 0.0);
  const bool valid = !(out.flags & kNonFiniteInput);
  // Wire velocities, once: > 0 toward the agonist for its wire, toward the antagonist for the other.
  const double agonist_wire_mps = models::wire_velocity_mps(r0, +1, in.velocity_radps);
  const double antagonist_wire_mps = models::wire_velocity_mps(r0, -1, in.velocity_radps);
  const MuscleCommand agonist =
      command_muscle(joint, joint.agonist, +1, agonist_joint_force_cmd_N, agonist_wire_mps, params, in, in.agonist_loadcell_N,
                     in.agonist_pressure_Pa, first, valid, data.force_trim_N[0]);
  const MuscleCommand antagonist =
      command_muscle(joint, joint.antagonist, -1, antagonist_joint_force_cmd_N, antagonist_wire_mps, params, in,
                     in.antagonist_loadcell_N, in.antagonist_pressure_Pa, first, valid, data.force_trim_N[1]);
  out.agonist_trim_N = data.force_trim_N[0];
  out.antagonist_trim_N = data.force_trim_N[1];
  out.agonist_force_cmd_N = agonist.force_N;
  out.antagonist_force_cmd_N = antagonist.force_N;
  out.agonist_pressure_Pa = agonist.pressure_Pa;
  out.antagonist_pressure_Pa = antagonist.pressure_Pa;
  out.agonist_contraction = agonist.contraction;
  out.antagonist_contraction = antagonist.contraction;
  if (agonist.clamped || antagonist.clamped) out.flags |= kForceClampedHigh;
  if (agonist.saturated || antagonist.saturated) out.flags |= kPressureSaturated;

  // Mini: the motor closes the gap between the desired and the measured PAM torque.
  const double agonist_joint_force_N =
      models::joint_force_from_loadcell_N(joint.agonist.bowden, in.agonist_loadcell_N, agonist_wire_mps);
  const double antagonist_joint_force_N =
      models::joint_force_from_loadcell_N(joint.antagonist.bowden, in.antagonist_loadcell_N, antagonist_wire_mps);
  out.tau_pam_measured_Nm = models::joint_torque_Nm(r0, agonist_joint_force_N, antagonist_joint_force_N, 0.0);
  out.tau_motor_cmd_Nm = 0.0;
  if (params.use_motor && joint.has_motor && !(out.flags & kNonFiniteInput)) {
    const double wanted = in.tau_desired_Nm - out.tau_pam_measured_Nm;
    out.tau_motor_cmd_Nm = std::clamp(wanted, -joint.motor_max_torque_Nm, joint.motor_max_torque_Nm);
    if (out.tau_motor_cmd_Nm != wanted) out.flags |= kMotorSaturated;
  }
}

}  // namespace peha::control
