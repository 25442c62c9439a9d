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
  double model_force_N;  ///< the pressure model's force at the measured pressure
  bool clamped;
  bool saturated;
  bool floor_held;       ///< the trim was held at the model's pretension floor
};

/// Checks one load cell against the pressure model (docs/models.md, "Load cells checked, not
/// trusted"): the disagreement, low-passed with `blend` (the filter's step weight), against a
/// tolerance that grows with the model's force, with hysteresis. Returns whether it is trusted now.
bool check_loadcell(const LoadcellCheck& c, double loadcell_N, double model_force_N, double blend, bool first,
                    double& disagreement_N, bool& ok) {
  const double d = loadcell_N - model_force_N;
  if (first) {
    disagreement_N = d;
  } else {
    disagreement_N += blend * (d - disagreement_N);
  }
  const double tolerance_N = c.tolerance_N + c.tolerance_fraction * std::max(model_force_N, 0.0);
  if (ok && std::abs(disagreement_N) > tolerance_N) ok = false;
  if (!ok && std::abs(disagreement_N) < c.rejoin_fraction * tolerance_N) ok = true;
  return ok;
}

/// `cable`: this muscle's cable with the friction the plant is sure to have;
/// `wire_velocity_mps`: this muscle's wire velocity (> 0 toward the muscle); `loadcell_N`: tared.
MuscleCommand command_muscle(const models::JointModel& joint, const models::MuscleModel& m, const models::BowdenParams& cable,
                             int side, double joint_force_N, double wire_velocity_mps, const AllocationParams& params,
                             const AllocationInput& in, double loadcell_N, double measured_pressure_Pa, bool first,
                             bool bumpless, bool sensors_valid, bool loadcell_ok, double contraction_offset, double& trim_N) {
  const double supply_Pa = joint.supply_pressure_Pa;
  const double wanted = models::muscle_force_for_joint_N(cable, joint_force_N, wire_velocity_mps);
  const double ceiling = models::force_ceiling_N(m);
  const double floor_N = std::min(joint.pretension_N, ceiling);
  const double force = std::clamp(wanted, floor_N, ceiling);
  const double eps = models::rigid_contraction(m, joint.pulley_radius_m, side, in.angle_rad) + contraction_offset;
  const double model_force_N = std::isfinite(measured_pressure_Pa) ? models::forward_force_N(m.pam, measured_pressure_Pa, eps) : 0.0;
  // The tension floor by the model: the trim may not take the model's force (force + trim) below
  // the pretension, whatever the load cell says.
  const double lowest_trim_N = std::max(-params.force_trim_max_N, floor_N - force);
  bool floor_held = false;
  models::InverseResult evaluated[2];  // muscle_pressure at evaluated_N[i], when evaluations > 0
  double evaluated_N[2] = {0.0, 0.0};
  int evaluations = 0;
  if (params.force_trim_rate_1ps > 0.0 && sensors_valid && first && bumpless && std::isfinite(measured_pressure_Pa)) {
    trim_N = std::clamp(model_force_N - force, lowest_trim_N, params.force_trim_max_N);  // what the model says P makes
  } else if (params.force_trim_rate_1ps > 0.0 && sensors_valid && loadcell_ok) {
    // Below the pretension the wire is near slack: the trim may integrate faster there (only upward);
    // not while the wires refill from the start-up's vent: that would wind the trim up against the
    // wires' take-up, and the muscle overshoots as its wire comes taut.
    const double rate_1ps = in.tension_expected && loadcell_N < floor_N && force > loadcell_N ? std::max(params.force_trim_rate_1ps, params.force_trim_slack_rate_1ps)
                                                                       : params.force_trim_rate_1ps;
    const double step = rate_1ps * (force - loadcell_N) * in.dt_s;
    const double next = trim_N + step;
    const double next_trim_N = std::clamp(next, lowest_trim_N, params.force_trim_max_N);
    // Anti-windup: do not integrate further into a saturated pressure. Only whether the pressure
    // now sits at 0 or at the supply matters: the residual is evaluated only when its bounds
    // cannot rule that out (the same decision), and then together with the command's pressure
    // should the trim move (the same contraction: one SPGP pass for both, the same bits).
    const models::PressureInterval range = models::muscle_pressure_interval(m, force + trim_N, eps, supply_Pa);
    bool at_top = false, at_bottom = false;
    if ((range.hi_Pa >= supply_Pa && step > 0.0) || (range.lo_Pa <= 0.0 && step < 0.0)) {
      evaluated_N[0] = force + trim_N;
      evaluated_N[1] = force + next_trim_N;
      models::muscle_pressure_pair(m, evaluated_N[0], evaluated_N[1], eps, supply_Pa, evaluated);
      evaluations = 2;
      at_top = evaluated[0].pressure_Pa >= supply_Pa && step > 0.0;
      at_bottom = evaluated[0].pressure_Pa <= 0.0 && step < 0.0;
    }
    if (!at_top && !at_bottom) {
      floor_held = next < lowest_trim_N;
      trim_N = next_trim_N;
    }
  }
  // A force request that rose since the last step (a lower floor for the trim) is kept too.
  if (trim_N < lowest_trim_N) trim_N = lowest_trim_N;
  const double command_N = force + trim_N;
  const auto inv = evaluations > 0 && command_N == evaluated_N[1]   ? evaluated[1]
                   : evaluations > 0 && command_N == evaluated_N[0] ? evaluated[0]
                                                                    : models::muscle_pressure(m, command_N, eps, supply_Pa);
  return {force, inv.pressure_Pa, eps, model_force_N, wanted > ceiling,
          inv.status == models::InverseStatus::kSaturated || inv.status == models::InverseStatus::kUnreachable, floor_held};
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
  p.force_trim_slack_rate_1ps = map.number_or("force_trim_slack_rate_1ps", p.force_trim_slack_rate_1ps, {0.0, 1000.0});
  p.sure_cable_friction_fraction = map.number_or("sure_cable_friction_fraction", p.sure_cable_friction_fraction, {0.0, 1.0});
  p.motor_damping_Nms_per_rad = map.number_or("motor_damping_Nms_per_rad", p.motor_damping_Nms_per_rad, {0.0, 100.0});
  if (map.has("loadcell_check")) {
    config::Map c = map.map("loadcell_check");
    LoadcellCheck& l = p.loadcell_check;
    l.tolerance_N = c.number_or("tolerance_N", l.tolerance_N, {0.0, 5000.0});
    l.tolerance_fraction = c.number_or("tolerance_fraction", l.tolerance_fraction, {0.0, 10.0});
    l.filter_Hz = c.number_or("filter_Hz", l.filter_Hz, {0.01, 500.0});
    l.rejoin_fraction = c.number_or("rejoin_fraction", l.rejoin_fraction, {0.0, 1.0});
    l.tare_s = c.number_or("tare_s", l.tare_s, {0.0, 10.0});
    l.vent_s = c.number_or("vent_s", l.vent_s, {0.0, 10.0});
    l.max_tare_N = c.number_or("max_tare_N", l.max_tare_N, {0.0, 2000.0});
    l.refill_s = c.number_or("refill_s", l.refill_s, {0.0, 10.0});
    c.finish();
  }
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
  // Only the cable friction the plant is sure to have is compensated (command and motor estimate).
  const models::BowdenParams agonist_cable = models::sure_friction(joint.agonist.bowden, params.sure_cable_friction_fraction);
  const models::BowdenParams antagonist_cable = models::sure_friction(joint.antagonist.bowden, params.sure_cable_friction_fraction);
  // Wire velocities, once: > 0 toward the agonist for its wire, toward the antagonist for the other.
  const double agonist_wire_mps = models::wire_velocity_mps(r0, +1, in.velocity_radps);
  const double antagonist_wire_mps = models::wire_velocity_mps(r0, -1, in.velocity_radps);
  const double agonist_loadcell_N = in.agonist_loadcell_N - data.loadcell_offset_N[0];
  const double antagonist_loadcell_N = in.antagonist_loadcell_N - data.loadcell_offset_N[1];
  const MuscleCommand agonist =
      command_muscle(joint, joint.agonist, agonist_cable, +1, agonist_joint_force_cmd_N, agonist_wire_mps, params, in,
                     agonist_loadcell_N, in.agonist_pressure_Pa, first, data.bumpless_start, valid, data.loadcell_ok[0],
                     data.contraction_offset[0], data.force_trim_N[0]);
  const MuscleCommand antagonist =
      command_muscle(joint, joint.antagonist, antagonist_cable, -1, antagonist_joint_force_cmd_N, antagonist_wire_mps, params,
                     in, antagonist_loadcell_N, in.antagonist_pressure_Pa, first, data.bumpless_start, valid,
                     data.loadcell_ok[1], data.contraction_offset[1], data.force_trim_N[1]);
  // Each load cell against the pressure model at the measured pressure (after this step's trim,
  // so a disagreement freezes the trim from the next step on).
  if (valid) {
    const double check_blend = 1.0 - std::exp(-2.0 * std::numbers::pi * params.loadcell_check.filter_Hz * in.dt_s);
    check_loadcell(params.loadcell_check, agonist_loadcell_N, agonist.model_force_N, check_blend, first, data.disagreement_N[0],
                   data.loadcell_ok[0]);
    check_loadcell(params.loadcell_check, antagonist_loadcell_N, antagonist.model_force_N, check_blend, first,
                   data.disagreement_N[1], data.loadcell_ok[1]);
  }
  out.model_force_N[0] = agonist.model_force_N;
  out.model_force_N[1] = antagonist.model_force_N;
  out.loadcell_ok[0] = data.loadcell_ok[0];
  out.loadcell_ok[1] = data.loadcell_ok[1];
  if (!data.loadcell_ok[0] || !data.loadcell_ok[1]) out.flags |= kLoadcellDisagrees;
  if (agonist.floor_held || antagonist.floor_held) out.flags |= kTensionFloorByModel;
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

  // Mini: the motor closes the gap between the desired and the measured PAM torque. A load cell
  // that disagrees with the model is replaced by the force asked of that muscle (no gap to close):
  // not by the model's force at the measured pressure, which near the pressure threshold is off by
  // hundreds of newtons and moves 54 N per kPa of sensor noise on a DMSP-40 - it saturated the
  // motor and dropped a lightly loaded shoulder 7 deg (upper body, sensor noise x3).
  const double agonist_force_N = data.loadcell_ok[0] ? agonist_loadcell_N : agonist.force_N;
  const double antagonist_force_N = data.loadcell_ok[1] ? antagonist_loadcell_N : antagonist.force_N;
  const double agonist_joint_force_N = models::joint_force_from_loadcell_N(agonist_cable, agonist_force_N, agonist_wire_mps);
  const double antagonist_joint_force_N =
      models::joint_force_from_loadcell_N(antagonist_cable, antagonist_force_N, antagonist_wire_mps);
  out.tau_pam_measured_Nm = models::joint_torque_Nm(r0, agonist_joint_force_N, antagonist_joint_force_N, 0.0);
  out.tau_motor_cmd_Nm = 0.0;
  if (params.use_motor && joint.has_motor && !(out.flags & kNonFiniteInput)) {
    const double wanted = in.tau_desired_Nm - out.tau_pam_measured_Nm - params.motor_damping_Nms_per_rad * in.velocity_radps;
    out.tau_motor_cmd_Nm = std::clamp(wanted, -joint.motor_max_torque_Nm, joint.motor_max_torque_Nm);
    if (out.tau_motor_cmd_Nm != wanted) out.flags |= kMotorSaturated;
  }
}

}  // namespace peha::control
