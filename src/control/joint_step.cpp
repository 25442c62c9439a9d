#include "peha/control/joint_step.hpp"

namespace peha::control {

void step_joint(const models::JointModel& joint, const AllocationParams& allocation, const CreepEstimatorParams& creep,
                const io::JointSensors& s, const JointStepInput& step, AllocationData& data, CreepEstimatorData& creep_data,
                AllocationInput& in, AllocationOutput& out) noexcept {
  // The creep estimator first: its correction shapes this step's command. It sees what the
  // allocation sees: tared load cells, measured pressures, the encoder, the last command.
  if (creep.enabled) {
    CreepEstimatorInput c;
    c.angle_rad = s.angle_rad;
    c.velocity_radps = step.velocity_radps;
    c.loadcell_N[0] = s.agonist_loadcell_N - data.loadcell_offset_N[0];
    c.loadcell_N[1] = s.antagonist_loadcell_N - data.loadcell_offset_N[1];
    c.pressure_Pa[0] = s.agonist_pressure_Pa;
    c.pressure_Pa[1] = s.antagonist_pressure_Pa;
    c.previous_pressure_cmd_Pa[0] = step.after_startup ? -1.0 : out.agonist_pressure_Pa;  // none yet: not settled
    c.previous_pressure_cmd_Pa[1] = step.after_startup ? -1.0 : out.antagonist_pressure_Pa;
    c.loadcell_ok[0] = data.loadcell_ok[0];
    c.loadcell_ok[1] = data.loadcell_ok[1];
    c.tension_expected = step.tension_expected;
    c.time_s = step.time_s;
    c.dt_s = step.dt_s;
    update_creep_estimator(joint, creep, creep_data, c);
    for (int i = 0; i < 2; ++i) {
      const double L0 = i == 0 ? joint.agonist.rest_length_m : joint.antagonist.rest_length_m;
      data.contraction_offset[i] = creep_correction_m(creep, creep_data, i) / L0;
    }
  }
  in.tau_desired_Nm = step.tau_desired_Nm;
  in.angle_rad = s.angle_rad;
  in.velocity_radps = step.velocity_radps;
  in.agonist_loadcell_N = s.agonist_loadcell_N;
  in.antagonist_loadcell_N = s.antagonist_loadcell_N;
  in.agonist_pressure_Pa = s.agonist_pressure_Pa;
  in.antagonist_pressure_Pa = s.antagonist_pressure_Pa;
  in.dt_s = step.dt_s;
  in.tension_expected = step.tension_expected;
  allocate(joint, allocation, data, in, out);
}

}  // namespace peha::control
