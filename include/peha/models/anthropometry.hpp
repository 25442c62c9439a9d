#pragma once
/// \file
/// The right arm's parameters: the user's (or mannequin's) arm segments from body height and mass
/// (anthropometric tables), the exoskeleton's links sized to that user, and the serial-chain
/// `ArmModel` of both plus a payload (docs/models.md). Conventions and sources: docs/right-arm.md.
///
/// Kinematic convention (world x forward, y to the user's left, z up; the shoulder joint centre at
/// (0, 0, shoulder_height_m)):
///
///     q = (R_SFE, R_EFE, R_WFE, R_WR, R_WAA)          (rad, in this order, a serial chain)
///     R_SFE = 0        upper arm horizontal, pointing forward (+x)
///     R_SFE = -pi/2    upper arm hanging straight down
///     R_EFE = 0        elbow straight; positive = flexion (the forearm turns forward/up)
///     R_WFE = 0        hand in line with the forearm; positive turns the hand the same way
///     R_SFE, R_EFE, R_WFE rotate about the joint frame's -y (positive lifts the distal part up when
///                      it points forward), R_WR about the link's long axis +x, R_WAA about +z.
///
/// Set-up code: throws on bad input; nothing here runs in the control loop.

#include "peha/config/reader.hpp"
#include "peha/models/arm.hpp"

#include <Eigen/Dense>

#include <array>
#include <string>

namespace peha::models {

/// Joint indices of the right arm's q vector (the order of `build_arm_model`'s joints).
enum RightArmJoint : int { kSFE = 0, kEFE = 1, kWFE = 2, kWR = 3, kWAA = 4 };
inline constexpr int kRightArmDof = 5;
inline constexpr std::array<const char*, kRightArmDof> kRightArmJointNames = {"R_SFE", "R_EFE", "R_WFE",
                                                                              "R_WR", "R_WAA"};

/// One row of an anthropometric table: everything as a fraction of body height / body mass /
/// segment length, plus the segment density.
struct SegmentFractions {
  double length_per_height;           ///< segment length / body height
  double mass_per_body_mass;          ///< segment mass / body mass
  double com_from_proximal;           ///< COM distance from the proximal joint / segment length
  double radius_of_gyration;          ///< about the COM (transverse axis) / segment length
  double density_kg_per_m3;           ///< used only for the (small) inertia about the long axis
};

/// Winter, "Biomechanics and Motor Control of Human Movement", 4th ed. (Wiley, 2009): lengths from
/// Fig. 4.1 (after Drillis & Contini 1966), mass / COM / radius of gyration / density from
/// Table 4.1 (Dempster 1955 via Miller & Nelson 1973 and Plagenhoef 1971).
namespace winter2009 {
inline constexpr SegmentFractions kUpperArm{0.186, 0.028, 0.436, 0.322, 1070.0};  ///< glenohumeral axis - elbow axis
inline constexpr SegmentFractions kForearm{0.146, 0.016, 0.430, 0.303, 1130.0};   ///< elbow axis - ulnar styloid
inline constexpr SegmentFractions kHand{0.108, 0.006, 0.506, 0.297, 1160.0};      ///< wrist axis - fingertip (Fig. 4.1)
}  // namespace winter2009

/// de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters", J. Biomech. 29(9),
/// 1996, Table 4 (living young adults, gamma-ray scanning, referenced to the joint centres): mass,
/// COM from the proximal joint centre, and the radii of gyration about the two transverse axes
/// (averaged: the models here have one transverse radius) and the long axis, as fractions.
/// Only the upper arm and forearm are used: de Leva's hand ends at the third metacarpal, Winter's
/// (and the exoskeleton's hand piece) at the fingertip, so the hand keeps Winter's row.
struct SexSegmentFractions {
  double mass_per_body_mass;
  double com_from_proximal;
  double radius_of_gyration;          ///< transverse, mean of de Leva's two
  double axial_radius_of_gyration;    ///< about the long axis
};
namespace deleva1996 {
inline constexpr SexSegmentFractions kMaleUpperArm{0.0271, 0.5772, 0.5 * (0.285 + 0.269), 0.158};
inline constexpr SexSegmentFractions kMaleForearm{0.0162, 0.4574, 0.5 * (0.276 + 0.265), 0.121};
inline constexpr SexSegmentFractions kFemaleUpperArm{0.0255, 0.5754, 0.5 * (0.278 + 0.260), 0.148};
inline constexpr SexSegmentFractions kFemaleForearm{0.0138, 0.4559, 0.5 * (0.261 + 0.257), 0.094};
}  // namespace deleva1996

/// Which table the user's segments come from: unspecified = Winter (2009), sex-neutral (the
/// default, and what the shipped right arm uses); male / female = de Leva (1996) for the upper arm
/// and forearm (lengths stay Winter's fractions of body height).
enum class Sex { kUnspecified, kMale, kFemale };

/// Valid inputs of `user_arm_from_anthropometry`.
inline constexpr double kMinHeight_m = 1.2, kMaxHeight_m = 2.2;
inline constexpr double kMinBodyMass_kg = 30.0, kMaxBodyMass_kg = 200.0;

/// One body segment. Its long axis is the joint frame's +x (proximal joint at the origin).
struct SegmentParams {
  double length_m = 0;
  double mass_kg = 0;
  double com_from_proximal_m = 0;
  double radius_of_gyration_m = 0;        ///< about the COM, transverse axes
  /// About the long axis: a uniform cylinder of the segment's length, mass and table density
  /// (r = sqrt(m / (pi rho L)), k = r / sqrt(2)); small, and only felt by R_WR.
  double axial_radius_of_gyration_m = 0;

  /// Inertia about the COM in the segment frame (x along the segment):
  /// diag(m k_axial^2, m k^2, m k^2).
  Eigen::Matrix3d inertia_kgm2() const;
};

struct UserArm {
  SegmentParams upper_arm, forearm, hand;
  double total_mass_kg() const { return upper_arm.mass_kg + forearm.mass_kg + hand.mass_kg; }
};

/// Segment parameters of a user of height `height_m` (m) and body mass `mass_kg` (kg) from Winter
/// (2009). Throws std::invalid_argument for heights outside [1.2, 2.2] m or masses outside
/// [30, 200] kg (or non-finite values).
UserArm user_arm_from_anthropometry(double height_m, double mass_kg, Sex sex = Sex::kUnspecified);

/// One exoskeleton link (rigid frame + cuff + whatever sits on it), long axis along the joint
/// frame's +x. Its COM is on that axis.
struct ExoLinkParams {
  double length_m = 0;                       ///< joint to next joint (= the user's segment)
  double mass_kg = 0;
  double com_fraction = 0.5;                 ///< COM from the proximal joint / length
  double radius_of_gyration_fraction = 0.3;  ///< about the COM, transverse axes / length
  double axial_radius_of_gyration_m = 0.03;  ///< about the long axis, m

  double com_m() const { return com_fraction * length_m; }
  Eigen::Matrix3d inertia_kgm2() const;      ///< about the COM, link frame
};

/// The exoskeleton arm from the shoulder joint to the tip (docs/models.md; paper §III: < 5 kg).
struct ExoArmParams {
  double shoulder_height_m = 1.40;           ///< world z of the R_SFE axis
  ExoLinkParams upper_link;                  ///< shoulder -> elbow, carries the elbow's motor/pulley
  ExoLinkParams forearm_link;                ///< elbow -> wrist, carries the wrist pulley
  ExoLinkParams hand_piece;                  ///< beyond the wrist joints (palm plate, WR/WAA bearings)

  double total_mass_kg() const { return upper_link.mass_kg + forearm_link.mass_kg + hand_piece.mass_kg; }
};

/// The nominal exoskeleton (the prototype's design values) with its link lengths set to `user`'s
/// segments: upper link = upper arm, forearm link = forearm, hand piece = hand.
ExoArmParams exo_arm_for_user(const UserArm& user);

/// The serial chain R_SFE, R_EFE, R_WFE, R_WR, R_WAA (see the file comment) with the bodies
/// "exo_upper_arm", "exo_forearm", "exo_hand" (+ "user_upper_arm", "user_forearm", "user_hand" when
/// `include_user_arm`) and "payload" (always present, mass `payload_kg` >= 0, a steel sphere at the
/// user's hand COM). The user's segments are strapped to the exo links: their COMs lie on the
/// link axes at com_from_proximal_m. Throws std::invalid_argument on non-physical input.
/// The paper's right arm alone (models/exoskeleton.hpp: `paper_right_arm_joints()`, one side).
ArmModel build_arm_model(const ExoArmParams& exo, const UserArm& user, double payload_kg, bool include_user_arm);

/// Throws std::invalid_argument ("build_arm_model: ...") for non-physical links or segments.
void check_arm_parameters(const ExoArmParams& exo, const UserArm& user);

// ---- configuration (configs/arm/right_arm_body.yaml) ----

/// Reads an `exoskeleton:` section: shoulder_height_m, upper_link{...}, forearm_link{...},
/// hand_piece{...} (each: mass_kg, com_fraction, radius_of_gyration_fraction,
/// axial_radius_of_gyration_m, optional length_m overriding the user's segment length). Link
/// lengths default to `sized_for`'s segments. The actuators (pulleys, muscles, motors) are the
/// scenario's (configs/right_arm.yaml), not the body's.
ExoArmParams read_exo_arm(config::Map map, const UserArm& sized_for);

/// Reads a `user:` section: height_m, mass_kg, optional sex (male, female; absent: Winter's
/// sex-neutral table), handedness (right, left; default right), upper_arm_mass_scale,
/// forearm_mass_scale, hand_mass_scale (default 1: a person or mannequin that deviates from the table).
struct UserSpec {
  double height_m = 1.75;
  double mass_kg = 70.0;
  Sex sex = Sex::kUnspecified;        ///< optional `sex: male | female`
  bool left_handed = false;           ///< optional `handedness: right | left` (its dominant side)
  double upper_arm_mass_scale = 1.0, forearm_mass_scale = 1.0, hand_mass_scale = 1.0;
  UserArm arm() const;  ///< user_arm_from_anthropometry + the mass scales
};
UserSpec read_user(config::Map map);

}  // namespace peha::models
