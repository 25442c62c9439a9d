#pragma once
/// \file
/// The controller's rigid-body model of the right arm (exoskeleton links + the user's or mannequin's
/// arm segments + payload), for gravity compensation tau = J^T G (docs/right-arm.md) and inverse dynamics.
///
/// A kinematic tree of revolute joints (a serial chain by default; both arms of an upper body are two
/// branches from the base). Joint i's frame is its parent's frame (the world for a root joint),
/// translated by `offset_m` (in the parent frame at q = 0) and then rotated by q_i about `axis`
/// (a unit vector in the joint's own frame). A joint's parent is listed before it, so one pass in
/// list order visits every parent before its children and one pass backwards every child first:
/// kinematics, gravity and inverse dynamics cost O(joints + bodies). Bodies are rigidly attached to a joint frame: mass,
/// centre of mass and rotational inertia about the COM, in that frame. World z points up; gravity is
/// (0, 0, -g). Model/Data split: `ArmModel` is constant, `ArmData` holds preallocated scratch.

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace peha::models {

/// `ArmJoint::parent` values that are not a joint index.
inline constexpr int kWorldParent = -1;     ///< a root joint: its offset is in the world frame
inline constexpr int kPreviousJoint = -2;   ///< the joint listed just before (the world for the first)

struct ArmJoint {
  std::string name;          ///< e.g. "R_SFE"
  Eigen::Vector3d offset_m;  ///< origin in the parent frame, m
  Eigen::Vector3d axis;      ///< unit rotation axis in the joint frame
  bool active = true;        ///< driven (SFE, EFE, WFE) or passive (WR, WAA)
  /// Index of the parent joint (< this joint's index), kWorldParent, or kPreviousJoint (a serial chain).
  int parent = kPreviousJoint;
};

struct ArmBody {
  std::string name;          ///< e.g. "exo_upper_arm", "user_forearm", "payload"
  int joint = 0;             ///< index of the joint frame it is attached to
  double mass_kg = 0;
  Eigen::Vector3d com_m;     ///< centre of mass in the joint frame, m
  Eigen::Matrix3d inertia_kgm2 = Eigen::Matrix3d::Zero();  ///< about the COM, in the joint frame
};

struct ArmModel {
  std::vector<ArmJoint> joints;
  std::vector<ArmBody> bodies;
  double gravity_mps2 = 9.81;
  int dof() const { return static_cast<int>(joints.size()); }
  /// Joint i's parent index, or -1 for a root (kPreviousJoint resolved to i - 1).
  int parent(int i) const noexcept {
    const int p = joints[static_cast<std::size_t>(i)].parent;
    return p == kPreviousJoint ? i - 1 : p;
  }
  /// True when joint `ancestor` is `joint` or lies on its path to the world (it moves `joint`'s frame).
  bool moves(int ancestor, int joint) const noexcept {
    for (int k = joint; k >= 0; k = parent(k)) {
      if (k == ancestor) return true;
    }
    return false;
  }
};

/// Throws std::invalid_argument unless every joint's parent is kWorldParent, kPreviousJoint or an
/// earlier joint, and every body hangs on an existing joint (names the joint or body).
void check_tree(const ArmModel& model);

/// Preallocated scratch sized for one model (construct once; the functions below do not allocate).
struct ArmData {
  explicit ArmData(const ArmModel& model);
  std::vector<Eigen::Matrix3d> R;   ///< world orientation of each joint frame
  std::vector<Eigen::Vector3d> p;   ///< world origin of each joint frame
  std::vector<Eigen::Vector3d> z;   ///< world joint axis
  Eigen::VectorXd tau;              ///< output torques, Nm
  Eigen::MatrixXd jacobian;         ///< 3 x dof scratch (COM Jacobian)
  std::vector<Eigen::Vector3d> omega, alpha, accel;  ///< per joint frame: angular velocity and
                                                     ///< acceleration, origin's linear acceleration
  std::vector<Eigen::Vector3d> force, moment;        ///< per body: net force, moment about its COM
  std::vector<double> subtree_mass_kg;               ///< per joint: mass its frame carries (gravity)
  std::vector<Eigen::Vector3d> subtree_first_moment_kgm;  ///< per joint: sum m c of those bodies (world)
  std::vector<Eigen::Vector3d> joint_force, joint_moment;  ///< per joint: what its subtree needs (RNEA),
                                                           ///< moment about the joint origin
};

/// Forward kinematics into `data` (R, p, z) for joint angles `q` (rad).
void forward_kinematics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept;

/// World position of body b's centre of mass (after forward_kinematics).
Eigen::Vector3d com_position(const ArmModel& model, const ArmData& data, int body) noexcept;

/// 3 x dof translational Jacobian of body b's centre of mass into data.jacobian (after forward_kinematics).
void com_jacobian(const ArmModel& model, ArmData& data, int body) noexcept;

/// Gravity compensation tau = sum_b J_b^T (m_b g e_z): the joint torques that hold the arm still
/// (Nm, into data.tau). Computed per joint from the mass m_i and first moment s_i = sum m_b c_b of
/// the bodies it carries (one backward pass): tau_i = g e_z . (z_i x (s_i - m_i p_i)).
/// noexcept, allocation-free.
const Eigen::VectorXd& gravity_torque(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept;

/// Inverse dynamics by recursive Newton-Euler: the joint torques (Nm, into data.tau) that produce
/// accelerations `qdd` (rad/s^2) at angles `q` and velocities `qd`, gravity included. The same
/// rigid-body equation MuJoCo's mj_inverse solves (without armature, damping or friction).
/// noexcept, allocation-free.
const Eigen::VectorXd& inverse_dynamics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& qd, const Eigen::VectorXd& qdd) noexcept;

}  // namespace peha::models
