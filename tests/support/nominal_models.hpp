#pragma once
// Nominal controller models shared by tests: the datasheet fits used in configs/e1_one_dof.yaml.
#include "peha/models/joint.hpp"

namespace peha::testing {

inline models::TendonSpringParams dmsp40_nominal() {
  models::TendonSpringParams p;
  p.a_N_per_Pa = 60951.0e-6;
  p.b_N_per_Pa = -48363.0e-6;
  p.c_N_per_Pa = 10199.0e-6;
  p.k_N = 8e4;
  p.eps0 = 0.005;
  return p;
}

/// The "true" muscle of synthetic calibration data (tests and benchmarks of the LM fit): a DMSP-40
/// like gain with an elastic wire (k = 6e4 N) and a little slack.
inline models::TendonSpringParams synthetic_truth() {
  models::TendonSpringParams p;
  p.a_N_per_Pa = 54000e-6;
  p.b_N_per_Pa = -48000e-6;
  p.c_N_per_Pa = 10050e-6;
  p.k_N = 6e4;
  p.eps0 = 0.005;
  return p;
}

inline models::TendonSpringParams dmsp10_nominal() {
  models::TendonSpringParams p;
  p.a_N_per_Pa = 16960.0e-6;
  p.b_N_per_Pa = -6337.0e-6;
  p.c_N_per_Pa = 763.0e-6;
  p.k_N = 1e5;
  p.eps0 = 0.0;
  return p;
}

inline models::JointModel rig_joint() {
  models::JointModel j;
  j.name = "joint";
  j.pulley_radius_m = 0.05;
  j.agonist = {"agonist", dmsp40_nominal(), {0.05, 3.14159, 200.0}, 0.40, 0.10, 2000.0, nullptr};
  j.antagonist = {"antagonist", dmsp10_nominal(), {0.05, 3.14159, 200.0}, 0.50, 0.06, 630.0, nullptr};
  j.has_motor = true;
  j.motor_max_torque_Nm = 2.5;
  return j;
}

}  // namespace peha::testing
