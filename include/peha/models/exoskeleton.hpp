#pragma once
/// \file
/// An exoskeleton described as data (docs/upper-body.md): one arm's joints as a list (name, parent,
/// where it sits, axis, range, whether it is driven), written once for the right arm; the sides that
/// are built (right, left, or both: a left arm is the right arm mirrored in the sagittal plane, not a
/// copied list); the user from anthropometry; the exoskeleton's links; the payload in each hand.
/// `build_exoskeleton_model` turns it into the rigid-body tree `ArmModel` (both arms are two branches
/// from the world), and `exoskeleton_joint_ranges` gives each joint's range and lock for the MJCF.
///
/// World frame: x forward, y to the user's left, z up. Each arm's root sits at its shoulder:
/// (0, -w/2, h) for the right arm, (0, +w/2, h) for the left (w = shoulder_width_m, h =
/// shoulder_height_m). Mirroring in the plane y = 0 (M = diag(1, -1, 1)): positions and centres of
/// mass become M x, inertia tensors M I M, and a rotation axis a becomes -M a (axes are
/// pseudo-vectors: the mirror image of a rotation by +q about a is a rotation by +q about -M a). So
/// flexion about -y stays about -y (positive flexion lifts the arm forward on both sides), and an
/// abduction about -x on the right is about +x on the left (positive abduction lifts each arm away
/// from the body).
///
/// Set-up code: throws std::invalid_argument (builder) or config::Error (readers).

#include "peha/config/reader.hpp"
#include "peha/models/anthropometry.hpp"
#include "peha/models/arm.hpp"

#include <string>
#include <string_view>
#include <vector>

namespace peha::models {

enum class ArmSide { kRight, kLeft };
/// "R" / "L": the prefix of that side's joint names ("R_SFE") and, on a two-armed body, its bodies.
const char* side_prefix(ArmSide side) noexcept;
/// `name` without its side prefix: "R_SFE" -> "SFE", "L_exo_forearm" -> "exo_forearm"; a name
/// without one ("SFE", "exo_forearm" on a one-armed body) as it is.
std::string_view without_side(std::string_view name) noexcept;

/// Where along the arm a joint's axis passes: its origin is the shoulder centre, the elbow
/// (upper-arm length beyond the last shoulder joint) or the wrist (forearm length beyond the last
/// elbow joint). The segments hang on the last joint of each site: the upper arm on the shoulder's,
/// the forearm on the elbow's, the hand (and the payload) on the wrist's.
enum class JointSite { kShoulder, kElbow, kWrist };

/// One joint of one arm as written for the right arm.
struct ArmJointSpec {
  std::string name;                 ///< without the side: "SFE" (the right arm's is "R_SFE")
  std::string parent;               ///< a joint of the same arm listed before, or "" (the shoulder)
  JointSite site = JointSite::kShoulder;
  Eigen::Vector3d axis = Eigen::Vector3d(0, -1, 0);  ///< unit axis in the joint's own frame (right arm)
  bool active = true;               ///< driven by an actuator (false: passive)
  double min_angle_rad = -3.14159265358979, max_angle_rad = 3.14159265358979;  ///< the joint's stops
  bool locked = false;              ///< held at `locked_at_rad` (the paper clamps the forearm rotation)
  double locked_at_rad = 0;
  double damping_Nms_per_rad = 0.05;  ///< bearing / passive tissue (the simulated plant's)
};

/// The right arm of the paper (Fig. 4): shoulder, elbow and wrist flexion (about -y) driven; the
/// forearm rotation (+x, clamped at 0) and the wrist's adduction-abduction (+z) passive.
std::vector<ArmJointSpec> paper_right_arm_joints();

/// One complete description of the exoskeleton and its wearer.
struct ExoskeletonSpec {
  UserSpec user_spec;
  UserArm user;                      ///< from user_spec (per side the same: anthropometry is symmetric)
  ExoArmParams exo;                  ///< links and shoulder height, the same on both sides
  double shoulder_width_m = 0;       ///< between the two shoulder centres (0 for a single arm at y = 0)
  std::vector<ArmJointSpec> arm_joints;  ///< one arm's joints, as the right arm
  std::vector<ArmSide> sides = {ArmSide::kRight};
  double payload_kg = 0;             ///< in each hand
  bool include_user_arm = true;
  ArmModel model() const;            ///< build_exoskeleton_model(*this)
};

/// The tree of every side's joints (sides in the listed order, each arm's joints in its list order;
/// joint names "<R|L>_<name>"). Bodies per side: "exo_upper_arm", "exo_forearm", "exo_hand",
/// "user_upper_arm", "user_forearm", "user_hand" (when include_user_arm) and "payload", prefixed
/// "<R|L>_" when more than one side is built (a single arm keeps the plain names). Throws
/// std::invalid_argument naming the joint for an unknown or later parent, a duplicate name, a site
/// that goes back toward the shoulder, a site with no joint, a non-unit axis or bad link/segment values.
ArmModel build_exoskeleton_model(const ExoskeletonSpec& spec);

/// Each model joint's range and lock, in the model's joint order (for sim::ArmMjcfOptions).
struct JointRange {
  double min_rad = 0, max_rad = 0;
  bool locked = false;
  double locked_at_rad = 0;
  double damping_Nms_per_rad = 0;
};
std::vector<JointRange> exoskeleton_joint_ranges(const ExoskeletonSpec& spec);

/// Reads an `arm_joints:` list item (keys name, parent, site, axis, passive, range_deg, locked_deg,
/// damping_Nms_per_rad; angles in degrees; parent `shoulder` for the arm's root) and `sides:`
/// (right, left, both, or dominant: the side of `user`'s handedness).
std::vector<ArmJointSpec> read_arm_joints(config::Map& map);
std::vector<ArmSide> read_sides(config::Map& map, const UserSpec& user);

/// A body file (configs/arm/right_arm_body.yaml, configs/arm/upper_body_body.yaml): the structure
/// (`sides`, `arm_joints`) once at the top level, shared by the controller's model (the top level's
/// user{...}, exoskeleton{...} with optional shoulder_width_m, payload_kg, include_user_arm) and the
/// simulated truth under `plant:` (the same keys, other values). Rejects unknown keys everywhere.
struct BodyConfig {
  ExoskeletonSpec controller;
  ExoskeletonSpec plant;
};
BodyConfig read_body(const config::Document& doc);

}  // namespace peha::models
