#pragma once
/// \file
/// MJCF of a `models::ArmModel` (a kinematic tree: the right arm's serial chain, or two arms on a base), so the simulated plant and the
/// controller's model can be built from one description (with different parameters: the plant's
/// truth is a second ArmModel, see configs/arm/right_arm_body.yaml and docs/right-arm.md).
///
/// Structure of the generated model:
/// - one MuJoCo body per group of joints, nested as the joints' parents are: a joint starts a new body
///   unless it is listed right after its parent, is its only child, sits at its origin (zero offset)
///   and no ArmBody hangs on the parent, in which case it joins the parent's body (MuJoCo chains
///   several joints of one body exactly like our serial
///   chain). The body is named "<first joint>_frame"; joints keep the ArmJoint names.
/// - every ArmBody is a welded child body of its joint's body, named like the ArmBody, with an
///   explicit <inertial> (mass, pos = com_m, diaginertia = inertia_kgm2; a non-diagonal tensor as
///   its principal axes (quat, diagonalised with Eigen) + diaginertia, exact to rounding), a
///   visual geom (contype/conaffinity 0: nothing touches anything) and a site "<body>_com".
/// - compiler angle="radian"; gravity (0, 0, -model.gravity_mps2).
/// Set-up code: throws std::invalid_argument / std::runtime_error.

#include "peha/models/arm.hpp"
#include "peha/models/exoskeleton.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <string>
#include <vector>

namespace peha::sim {

/// Per-joint MJCF settings.
struct ArmMjcfJoint {
  double range_min_rad = -3.14159265358979;
  double range_max_rad = 3.14159265358979;
  double damping_Nms_per_rad = 0.0;     ///< viscous (bearing / passive tissue)
  double armature_kgm2 = 0.0;           ///< mechanical only; the plant adds the motor's reflected inertia
  double stiffness_Nm_per_rad = 0.0;    ///< passive spring toward `spring_ref_rad`
  double spring_ref_rad = 0.0;
  bool locked = false;                  ///< held at `locked_at_rad` by an equality constraint (e.g. R_WR clamped)
  double locked_at_rad = 0.0;
};

struct ArmMjcfOptions {
  std::string model_name = "peha_right_arm";
  double timestep_s = 0.0005;
  std::string integrator = "Euler";     ///< "Euler", "RK4" or "implicit"
  std::vector<ArmMjcfJoint> joints;     ///< one per ArmModel joint, or empty: `default_joint` for all
  ArmMjcfJoint default_joint;
  double geom_radius_m = 0.02;          ///< visual only (inertia comes from <inertial>)
};

/// Each joint's range, lock and damping from the body's joint list (models::exoskeleton_joint_ranges),
/// named "peha_right_arm", "peha_left_arm" or "peha_upper_body".
ArmMjcfOptions exoskeleton_mjcf_options(const models::ExoskeletonSpec& spec);

/// The paper's right arm (models::paper_right_arm_joints(), 5 joints): ranges
/// SFE [-100, 60] deg, EFE [0, 135] deg, WFE [-60, 60] deg, WR [-80, 80] deg, WAA [-30, 20] deg;
/// small bearing damping on the exo joints, passive-tissue damping on the wrist; WR clamped at 0 as in
/// the paper's experiments.
ArmMjcfOptions arm_mjcf_options();

/// The complete MJCF document (see the file comment). Throws std::invalid_argument if the model or
/// the options are unusable (bad names, non-finite numbers, wrong option count, empty range, a
/// moving MuJoCo body that would carry no mass).
std::string arm_mjcf(const models::ArmModel& model, const ArmMjcfOptions& options);

/// Loads MJCF text through a uniquely named temporary file (removed again, also on failure).
/// Throws std::runtime_error with MuJoCo's message.
ModelPtr load_arm_mjcf(const std::string& xml);

}  // namespace peha::sim
