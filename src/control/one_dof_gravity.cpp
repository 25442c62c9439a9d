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
    : model_(std::move(model)) {
  velocity_.cutoff_Hz = model_.velocity_cutoff_Hz;
  if (model_.allocation.loadcell_check.tare_s > 0.0) diag_.phase = StartupPhase::kVenting;
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

  // Start-up tare: both muscles are commanded vented. The limits layer keeps the model's
  // pretension pressure, which in the rig's muscles is below their pressure threshold, so they make
  // (almost) no force and what the load cells read is their offset. The hand holds the link
  // meanwhile (E1's initial hold); the motor is off.
  if (diag_.phase != StartupPhase::kCompensating) {
    const LoadcellCheck& check = model_.allocation.loadcell_check;
    if (first) phase_start_s_ = state.time_s;
    const double elapsed_s = state.time_s - phase_start_s_;
    if (diag_.phase == StartupPhase::kVenting && elapsed_s >= check.vent_s) {
      diag_.phase = StartupPhase::kTaring;
      phase_start_s_ = state.time_s;
    } else if (diag_.phase == StartupPhase::kTaring && std::isfinite(s.agonist_loadcell_N) &&
               std::isfinite(s.antagonist_loadcell_N)) {
      tare_sum_N_[0] += s.agonist_loadcell_N;
      tare_sum_N_[1] += s.antagonist_loadcell_N;
      ++tare_samples_;
      if (elapsed_s >= check.tare_s) {
        for (int i = 0; i < 2; ++i) {
          const double offset_N = tare_sum_N_[i] / static_cast<double>(tare_samples_);
          allocation_data_.loadcell_offset_N[i] = std::abs(offset_N) <= check.max_tare_N ? offset_N : 0.0;
          diag_.loadcell_offset_N[i] = allocation_data_.loadcell_offset_N[i];
        }
        allocation_data_.bumpless_start = false;  // the valves start from vented, the trim from 0
        diag_.phase = StartupPhase::kCompensating;
      }
    }
    if (diag_.phase != StartupPhase::kCompensating) {
      diag_.allocation = AllocationOutput{};
      command.joints[0] = {0.0, 0.0, 0.0};
      return;
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
