#include "peha/control/one_dof_gravity.hpp"

#include <cmath>
#include <numbers>

namespace peha::control {

double gravity_torque_Nm(const OneDofGravityModel& g, double angle_rad) noexcept {
  const double moment_kgm = g.link_mass_kg * g.link_com_m + g.payload_mass_kg * g.payload_lever_m;
  return g.gravity_mps2 * moment_kgm * std::cos(angle_rad);
}

double VelocityEstimator::update(double angle_rad, double dt_s) noexcept {
  if (!std::isfinite(angle_rad) || !(dt_s > 0.0)) return velocity_radps;
  if (!initialized) {
    previous_angle_rad = angle_rad;
    velocity_radps = 0.0;
    initialized = true;
    return velocity_radps;
  }
  const double raw = (angle_rad - previous_angle_rad) / dt_s;
  previous_angle_rad = angle_rad;
  const double blend = 1.0 - std::exp(-2.0 * std::numbers::pi * cutoff_Hz * dt_s);
  velocity_radps += blend * (raw - velocity_radps);
  return velocity_radps;
}

OneDofGravityController::OneDofGravityController(OneDofControllerModel model)
    : model_(std::move(model)), tare_(start_tare(model_.allocation.loadcell_check)) {
  velocity_.cutoff_Hz = model_.velocity_cutoff_Hz;
  diag_.phase = tare_.phase;
  // Without a start-up tare, each load cell's zero is what its muscle model knows (a calibration's
  // recording measured it; 0 otherwise). A tare, when it runs, measures it again.
  allocation_data_.loadcell_offset_N[0] = diag_.loadcell_offset_N[0] = model_.joint.agonist.loadcell_zero_N;
  allocation_data_.loadcell_offset_N[1] = diag_.loadcell_offset_N[1] = model_.joint.antagonist.loadcell_zero_N;
}

void OneDofGravityController::update(const io::SensorState& state, io::Command& command) noexcept {
  const io::JointSensors& s = state.joints[0];
  const double dt_s = started_ ? state.time_s - last_time_s_ : 0.0;
  last_time_s_ = state.time_s;
  const bool first = !started_;
  started_ = true;

  diag_.velocity_radps = velocity_.update(s.angle_rad, dt_s);
  diag_.tau_desired_Nm = gravity_torque_Nm(model_.gravity, s.angle_rad);
  command.joint_count = 1;

  // Start-up tare (control/startup_tare.hpp): both muscles commanded vented, the motor off, while
  // the hand holds the link (E1's initial hold); then the load cells' offsets are subtracted.
  const LoadcellCheck& check = model_.allocation.loadcell_check;
  const bool was_starting = tare_.phase != StartupPhase::kCompensating;
  const bool venting = step_startup_tare(check, state, tare_);
  diag_.phase = tare_.phase;
  if (venting) {
    diag_.allocation = AllocationOutput{};
    command.joints[0] = {0.0, 0.0, 0.0};
    return;
  }
  if (was_starting) {
    for (int i = 0; i < 2; ++i) {
      allocation_data_.loadcell_offset_N[i] = tare_offset_N(check, tare_, 0, i);
      diag_.loadcell_offset_N[i] = allocation_data_.loadcell_offset_N[i];
    }
    allocation_data_.bumpless_start = false;  // the valves start from vented, the trim from 0
  }

  // The creep estimator (before the allocation: its correction shapes this step's command). It sees
  // what the allocation sees: tared load cells, measured pressures, the encoder, the last command.
  if (model_.creep.enabled) {
    CreepEstimatorInput c;
    c.angle_rad = s.angle_rad;
    c.velocity_radps = diag_.velocity_radps;
    c.loadcell_N[0] = s.agonist_loadcell_N - allocation_data_.loadcell_offset_N[0];
    c.loadcell_N[1] = s.antagonist_loadcell_N - allocation_data_.loadcell_offset_N[1];
    c.pressure_Pa[0] = s.agonist_pressure_Pa;
    c.pressure_Pa[1] = s.antagonist_pressure_Pa;
    c.previous_pressure_cmd_Pa[0] = was_starting ? -1.0 : diag_.allocation.agonist_pressure_Pa;  // none yet: not settled
    c.previous_pressure_cmd_Pa[1] = was_starting ? -1.0 : diag_.allocation.antagonist_pressure_Pa;
    c.loadcell_ok[0] = allocation_data_.loadcell_ok[0];
    c.loadcell_ok[1] = allocation_data_.loadcell_ok[1];
    c.tension_expected = !wires_slack_on_purpose(state.time_s);
    c.time_s = state.time_s;
    c.dt_s = first || !(dt_s > 0.0) ? model_.allocation.period_s : dt_s;
    update_creep_estimator(model_.joint, model_.creep, diag_.creep, c);
    for (int i = 0; i < 2; ++i) {
      const double L0 = i == 0 ? model_.joint.agonist.rest_length_m : model_.joint.antagonist.rest_length_m;
      allocation_data_.contraction_offset[i] = creep_correction_m(model_.creep, diag_.creep, i) / L0;
    }
  }

  AllocationInput& in = diag_.allocation_input;
  in.tau_desired_Nm = diag_.tau_desired_Nm;
  in.angle_rad = s.angle_rad;
  in.velocity_radps = diag_.velocity_radps;
  in.agonist_loadcell_N = s.agonist_loadcell_N;
  in.antagonist_loadcell_N = s.antagonist_loadcell_N;
  in.agonist_pressure_Pa = s.agonist_pressure_Pa;
  in.antagonist_pressure_Pa = s.antagonist_pressure_Pa;
  in.dt_s = first || !(dt_s > 0.0) ? model_.allocation.period_s : dt_s;
  allocate(model_.joint, model_.allocation, allocation_data_, in, diag_.allocation);

  command.joints[0].agonist_pressure_Pa = diag_.allocation.agonist_pressure_Pa;
  command.joints[0].antagonist_pressure_Pa = diag_.allocation.antagonist_pressure_Pa;
  command.joints[0].motor_torque_Nm = diag_.allocation.tau_motor_cmd_Nm;
}

}  // namespace peha::control
