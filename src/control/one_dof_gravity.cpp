#include "peha/control/one_dof_gravity.hpp"

#include "peha/control/joint_step.hpp"

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

void OneDofGravityController::update(const io::SensorState& raw, io::Command& command) noexcept {
  // The sensor check's corrections first: the tare then measures only what is left of the zero.
  io::SensorState state = raw;
  io::JointSensors& s = state.joints[0];
  s.agonist_loadcell_N = corrected_loadcell_N(model_.loadcell[0], s.agonist_loadcell_N);
  s.antagonist_loadcell_N = corrected_loadcell_N(model_.loadcell[1], s.antagonist_loadcell_N);
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
    command.joints[0] = {0.0, 0.0, 0.0, declared_zero(allocation_data_)};
    return;
  }
  if (was_starting) {
    for (int i = 0; i < 2; ++i) {
      allocation_data_.loadcell_offset_N[i] = tare_offset_N(check, tare_, 0, i);
      diag_.loadcell_offset_N[i] = allocation_data_.loadcell_offset_N[i];
    }
    allocation_data_.bumpless_start = false;  // the valves start from vented, the trim from 0
  }

  JointStepInput step;
  step.tau_desired_Nm = diag_.tau_desired_Nm;
  step.velocity_radps = diag_.velocity_radps;
  step.time_s = state.time_s;
  step.dt_s = first || !(dt_s > 0.0) ? model_.allocation.period_s : dt_s;
  step.after_startup = was_starting;
  step.tension_expected = !wires_slack_on_purpose(state.time_s);
  step_joint(model_.joint, model_.allocation, model_.creep, s, step, allocation_data_, diag_.creep, diag_.allocation_input, diag_.allocation);

  command.joints[0].agonist_pressure_Pa = diag_.allocation.agonist_pressure_Pa;
  command.joints[0].antagonist_pressure_Pa = diag_.allocation.antagonist_pressure_Pa;
  command.joints[0].motor_torque_Nm = diag_.allocation.tau_motor_cmd_Nm;
  command.joints[0].loadcell_zero_N = declared_zero(allocation_data_);
}

}  // namespace peha::control
