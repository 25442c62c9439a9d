#include "peha/models/anthropometry.hpp"
#include "peha/models/exoskeleton.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace peha::models {
namespace {

SegmentParams segment(const SegmentFractions& f, double height_m, double mass_kg) {
  SegmentParams s;
  s.length_m = f.length_per_height * height_m;
  s.mass_kg = f.mass_per_body_mass * mass_kg;
  s.com_from_proximal_m = f.com_from_proximal * s.length_m;
  s.radius_of_gyration_m = f.radius_of_gyration * s.length_m;
  const double radius_m = std::sqrt(s.mass_kg / (std::numbers::pi * f.density_kg_per_m3 * s.length_m));
  s.axial_radius_of_gyration_m = radius_m / std::numbers::sqrt2;
  return s;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("build_arm_model: " + what);
}

void check_link(const ExoLinkParams& l, const char* name) {
  require(std::isfinite(l.length_m) && l.length_m > 0, fmt::format("{}.length_m must be > 0", name));
  require(std::isfinite(l.mass_kg) && l.mass_kg >= 0, fmt::format("{}.mass_kg must be >= 0", name));
  require(std::isfinite(l.com_fraction) && l.com_fraction >= 0 && l.com_fraction <= 1,
          fmt::format("{}.com_fraction must be in [0, 1]", name));
  require(std::isfinite(l.radius_of_gyration_fraction) && l.radius_of_gyration_fraction >= 0,
          fmt::format("{}.radius_of_gyration_fraction must be >= 0", name));
  require(std::isfinite(l.axial_radius_of_gyration_m) && l.axial_radius_of_gyration_m >= 0,
          fmt::format("{}.axial_radius_of_gyration_m must be >= 0", name));
}

void check_segment(const SegmentParams& s, const char* name) {
  require(std::isfinite(s.length_m) && s.length_m > 0, fmt::format("user {} length must be > 0", name));
  require(std::isfinite(s.mass_kg) && s.mass_kg >= 0, fmt::format("user {} mass must be >= 0", name));
  require(std::isfinite(s.com_from_proximal_m) && std::isfinite(s.radius_of_gyration_m) &&
              std::isfinite(s.axial_radius_of_gyration_m) && s.radius_of_gyration_m >= 0 &&
              s.axial_radius_of_gyration_m >= 0,
          fmt::format("user {} COM / radii of gyration must be finite and >= 0", name));
}

Eigen::Matrix3d slender(double mass_kg, double axial_k_m, double transverse_k_m) {
  return Eigen::Vector3d(mass_kg * axial_k_m * axial_k_m, mass_kg * transverse_k_m * transverse_k_m,
                         mass_kg * transverse_k_m * transverse_k_m)
      .asDiagonal();
}

ExoLinkParams read_link(config::Map map, double default_length_m) {
  ExoLinkParams l;
  l.length_m = map.number_or("length_m", default_length_m, {0.02, 1.0});
  l.mass_kg = map.number("mass_kg", {0.0, 10.0});
  l.com_fraction = map.number("com_fraction", {0.0, 1.0});
  l.radius_of_gyration_fraction = map.number("radius_of_gyration_fraction", {0.0, 1.0});
  l.axial_radius_of_gyration_m = map.number("axial_radius_of_gyration_m", {0.0, 0.2});
  map.finish();
  return l;
}

}  // namespace

Eigen::Matrix3d SegmentParams::inertia_kgm2() const {
  return slender(mass_kg, axial_radius_of_gyration_m, radius_of_gyration_m);
}

Eigen::Matrix3d ExoLinkParams::inertia_kgm2() const {
  return slender(mass_kg, axial_radius_of_gyration_m, radius_of_gyration_fraction * length_m);
}

UserArm user_arm_from_anthropometry(double height_m, double mass_kg, Sex sex) {
  if (!std::isfinite(height_m) || height_m < kMinHeight_m || height_m > kMaxHeight_m) {
    throw std::invalid_argument(fmt::format(
        "user_arm_from_anthropometry: body height {} m is outside [{}, {}] m", height_m, kMinHeight_m, kMaxHeight_m));
  }
  if (!std::isfinite(mass_kg) || mass_kg < kMinBodyMass_kg || mass_kg > kMaxBodyMass_kg) {
    throw std::invalid_argument(fmt::format("user_arm_from_anthropometry: body mass {} kg is outside [{}, {}] kg",
                                            mass_kg, kMinBodyMass_kg, kMaxBodyMass_kg));
  }
  UserArm arm;
  arm.upper_arm = segment(winter2009::kUpperArm, height_m, mass_kg);
  arm.forearm = segment(winter2009::kForearm, height_m, mass_kg);
  arm.hand = segment(winter2009::kHand, height_m, mass_kg);
  if (sex != Sex::kUnspecified) {
    const bool male = sex == Sex::kMale;
    auto apply = [mass_kg](SegmentParams& s, const SexSegmentFractions& f) {
      s.mass_kg = f.mass_per_body_mass * mass_kg;
      s.com_from_proximal_m = f.com_from_proximal * s.length_m;
      s.radius_of_gyration_m = f.radius_of_gyration * s.length_m;
      s.axial_radius_of_gyration_m = f.axial_radius_of_gyration * s.length_m;
    };
    apply(arm.upper_arm, male ? deleva1996::kMaleUpperArm : deleva1996::kFemaleUpperArm);
    apply(arm.forearm, male ? deleva1996::kMaleForearm : deleva1996::kFemaleForearm);
  }
  return arm;
}

ExoArmParams exo_arm_for_user(const UserArm& user) {
  // Design values of the prototype (docs/right-arm.md): aluminium frames, cuffs and belts, the
  // elbow's motor (EC-4pole 30 + 14:1 + bevel) and pulley near the distal end of the upper link,
  // the wrist's pulley on the forearm link, the palm plate with the passive WR/WAA bearings.
  ExoArmParams exo;
  exo.upper_link = {user.upper_arm.length_m, 2.0, 0.60, 0.35, 0.04};
  exo.forearm_link = {user.forearm.length_m, 1.4, 0.40, 0.32, 0.035};
  exo.hand_piece = {user.hand.length_m, 0.5, 0.30, 0.30, 0.03};
  return exo;
}

void check_arm_parameters(const ExoArmParams& exo, const UserArm& user) {
  check_link(exo.upper_link, "upper_link");
  check_link(exo.forearm_link, "forearm_link");
  check_link(exo.hand_piece, "hand_piece");
  check_segment(user.upper_arm, "upper arm");
  check_segment(user.forearm, "forearm");
  check_segment(user.hand, "hand");
  require(std::isfinite(exo.shoulder_height_m), "shoulder_height_m must be finite");
}

ArmModel build_arm_model(const ExoArmParams& exo, const UserArm& user, double payload_kg, bool include_user_arm) {
  ExoskeletonSpec spec;
  spec.exo = exo;
  spec.user = user;
  spec.arm_joints = paper_right_arm_joints();
  spec.payload_kg = payload_kg;
  spec.include_user_arm = include_user_arm;
  return build_exoskeleton_model(spec);
}

ExoArmParams read_exo_arm(config::Map map, const UserArm& sized_for) {
  ExoArmParams exo;
  exo.shoulder_height_m = map.number("shoulder_height_m", {0.0, 3.0});
  exo.upper_link = read_link(map.map("upper_link"), sized_for.upper_arm.length_m);
  exo.forearm_link = read_link(map.map("forearm_link"), sized_for.forearm.length_m);
  exo.hand_piece = read_link(map.map("hand_piece"), sized_for.hand.length_m);
  map.finish();
  return exo;
}

UserArm UserSpec::arm() const {
  UserArm a = user_arm_from_anthropometry(height_m, mass_kg, sex);
  a.upper_arm.mass_kg *= upper_arm_mass_scale;
  a.forearm.mass_kg *= forearm_mass_scale;
  a.hand.mass_kg *= hand_mass_scale;
  return a;
}

UserSpec read_user(config::Map map) {
  UserSpec u;
  u.height_m = map.number("height_m", {kMinHeight_m, kMaxHeight_m});
  u.mass_kg = map.number("mass_kg", {kMinBodyMass_kg, kMaxBodyMass_kg});
  if (map.has("sex")) u.sex = map.choice("sex", {"male", "female"}) == "male" ? Sex::kMale : Sex::kFemale;
  u.left_handed = map.has("handedness") && map.choice("handedness", {"right", "left"}) == "left";
  u.upper_arm_mass_scale = map.number_or("upper_arm_mass_scale", 1.0, {0.5, 2.0});
  u.forearm_mass_scale = map.number_or("forearm_mass_scale", 1.0, {0.5, 2.0});
  u.hand_mass_scale = map.number_or("hand_mass_scale", 1.0, {0.5, 2.0});
  map.finish();
  return u;
}

}  // namespace peha::models
