#include "peha/models/exoskeleton.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace peha::models {
namespace {

constexpr double kSteelDensity_kg_per_m3 = 7850.0;

void require_exoskeleton(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("exoskeleton: " + what);
}

const char* site_name(JointSite s) {
  switch (s) {
    case JointSite::kShoulder: return "shoulder";
    case JointSite::kElbow: return "elbow";
    case JointSite::kWrist: return "wrist";
  }
  return "?";
}

/// Index in `joints` of the joint called `name`, or -1.
int find_joint(const std::vector<ArmJointSpec>& joints, const std::string& name, std::size_t before) {
  for (std::size_t i = 0; i < before; ++i) {
    if (joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

/// Checks the one-arm list and returns, per site, the joint the segment beyond it hangs on (the
/// last joint of that site no joint of the same site names as parent).
std::array<int, 3> check_arm(const std::vector<ArmJointSpec>& joints) {
  require_exoskeleton(!joints.empty(), "the arm has no joints");
  std::array<int, 3> last{-1, -1, -1};
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const ArmJointSpec& j = joints[i];
    require_exoskeleton(!j.name.empty(), fmt::format("joint {} has no name", i));
    require_exoskeleton(find_joint(joints, j.name, i) < 0, fmt::format("joint '{}' is listed twice", j.name));
    require_exoskeleton(j.axis.allFinite() && std::abs(j.axis.norm() - 1.0) < 1e-9, fmt::format("joint '{}' needs a unit axis", j.name));
    require_exoskeleton(std::isfinite(j.min_angle_rad) && std::isfinite(j.max_angle_rad) && j.min_angle_rad < j.max_angle_rad,
            fmt::format("joint '{}' needs a range with min < max", j.name));
    require_exoskeleton(!j.locked || (j.locked_at_rad >= j.min_angle_rad && j.locked_at_rad <= j.max_angle_rad),
            fmt::format("joint '{}' is locked outside its range", j.name));
    require_exoskeleton(std::isfinite(j.damping_Nms_per_rad) && j.damping_Nms_per_rad >= 0, fmt::format("joint '{}' needs damping >= 0", j.name));
    if (j.parent.empty()) {
      require_exoskeleton(j.site == JointSite::kShoulder, fmt::format("joint '{}' has no parent, so it sits at the shoulder, not the {}", j.name,
                                                          site_name(j.site)));
    } else {
      const int p = find_joint(joints, j.parent, i);
      require_exoskeleton(p >= 0, fmt::format("joint '{}' names parent '{}', which is not a joint listed before it", j.name, j.parent));
      const JointSite ps = joints[static_cast<std::size_t>(p)].site;
      require_exoskeleton(static_cast<int>(j.site) >= static_cast<int>(ps) && static_cast<int>(j.site) <= static_cast<int>(ps) + 1,
              fmt::format("joint '{}' at the {} cannot follow '{}' at the {} (shoulder -> elbow -> wrist, one step at a time)",
                          j.name, site_name(j.site), j.parent, site_name(ps)));
    }
  }
  for (int site = 0; site < 3; ++site) {
    for (std::size_t i = 0; i < joints.size(); ++i) {
      if (static_cast<int>(joints[i].site) != site) continue;
      bool has_same_site_child = false;
      for (const ArmJointSpec& c : joints) has_same_site_child |= c.parent == joints[i].name && c.site == joints[i].site;
      if (has_same_site_child) continue;
      if (last[static_cast<std::size_t>(site)] >= 0) {
        require_exoskeleton(false, fmt::format("the {} has two last joints ('{}' and '{}'): its joints must form one chain",
                                   site_name(static_cast<JointSite>(site)),
                                   joints[static_cast<std::size_t>(last[static_cast<std::size_t>(site)])].name, joints[i].name));
      }
      last[static_cast<std::size_t>(site)] = static_cast<int>(i);
    }
    require_exoskeleton(last[static_cast<std::size_t>(site)] >= 0, fmt::format("no joint sits at the {}", site_name(static_cast<JointSite>(site))));
  }
  return last;
}

}  // namespace

const char* side_prefix(ArmSide side) noexcept { return side == ArmSide::kRight ? "R" : "L"; }

std::string_view without_side(std::string_view name) noexcept {
  for (const ArmSide side : {ArmSide::kRight, ArmSide::kLeft}) {
    const std::string_view prefix = side_prefix(side);
    if (name.size() > prefix.size() + 1 && name.starts_with(prefix) && name[prefix.size()] == '_') return name.substr(prefix.size() + 1);
  }
  return name;
}

std::vector<ArmJointSpec> paper_right_arm_joints() {
  const Eigen::Vector3d flexion(0, -1, 0);  // positive turns +x toward +z (up)
  std::vector<ArmJointSpec> j(5);
  j[0] = {"SFE", "", JointSite::kShoulder, flexion, true, deg_to_rad(-100), deg_to_rad(60), false, 0, 0.05};
  j[1] = {"EFE", "SFE", JointSite::kElbow, flexion, true, 0, deg_to_rad(135), false, 0, 0.05};
  j[2] = {"WFE", "EFE", JointSite::kWrist, flexion, true, deg_to_rad(-60), deg_to_rad(60), false, 0, 0.05};
  j[3] = {"WR", "WFE", JointSite::kWrist, Eigen::Vector3d::UnitX(), false, deg_to_rad(-80), deg_to_rad(80), true, 0, 0.05};
  j[4] = {"WAA", "WR", JointSite::kWrist, Eigen::Vector3d::UnitZ(), false, deg_to_rad(-30), deg_to_rad(20), false, 0, 0.05};
  return j;
}

ArmModel build_exoskeleton_model(const ExoskeletonSpec& spec) {
  const std::array<int, 3> carrier = check_arm(spec.arm_joints);
  require_exoskeleton(!spec.sides.empty(), "no side to build");
  require_exoskeleton(spec.sides.size() <= 2 && (spec.sides.size() == 1 || spec.sides[0] != spec.sides[1]), "each side at most once");
  require_exoskeleton(std::isfinite(spec.shoulder_width_m) && spec.shoulder_width_m >= 0, "shoulder_width_m must be >= 0");
  require_exoskeleton(std::isfinite(spec.payload_kg) && spec.payload_kg >= 0, "payload_kg must be finite and >= 0");
  check_arm_parameters(spec.exo, spec.user);

  const Eigen::Matrix3d mirror = Eigen::Vector3d(1, -1, 1).asDiagonal();
  const double segment_offset_m[3] = {0.0, spec.exo.upper_link.length_m, spec.exo.forearm_link.length_m};
  const bool prefixed_bodies = spec.sides.size() > 1;
  ArmModel m;
  for (const ArmSide side : spec.sides) {
    const bool left = side == ArmSide::kLeft;
    const int first = m.dof();
    const std::string prefix = std::string(side_prefix(side)) + "_";
    const std::string body_prefix = prefixed_bodies ? prefix : "";
    auto place = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d { return left ? Eigen::Vector3d(mirror * v) : v; };
    for (std::size_t i = 0; i < spec.arm_joints.size(); ++i) {
      const ArmJointSpec& s = spec.arm_joints[i];
      ArmJoint j;
      j.name = prefix + s.name;
      j.active = s.active;
      j.axis = left ? Eigen::Vector3d(-(mirror * s.axis)) : s.axis;
      if (s.parent.empty()) {
        j.parent = kWorldParent;
        j.offset_m = Eigen::Vector3d(0, (left ? 0.5 : -0.5) * spec.shoulder_width_m, spec.exo.shoulder_height_m);
      } else {
        const int p = find_joint(spec.arm_joints, s.parent, i);
        j.parent = first + p;
        const bool next_site = s.site != spec.arm_joints[static_cast<std::size_t>(p)].site;
        j.offset_m = place(Eigen::Vector3d(next_site ? segment_offset_m[static_cast<int>(s.site)] : 0.0, 0, 0));
      }
      m.joints.push_back(j);
    }
    auto add = [&](const std::string& name, int site, double mass_kg, const Eigen::Vector3d& com_m, const Eigen::Matrix3d& inertia) {
      const int joint = first + carrier[static_cast<std::size_t>(site)];
      const Eigen::Matrix3d I = left ? Eigen::Matrix3d(mirror * inertia * mirror) : inertia;
      m.bodies.push_back(ArmBody{body_prefix + name, joint, mass_kg, place(com_m), I});
    };
    auto link = [&](const std::string& name, int site, const ExoLinkParams& l) {
      add(name, site, l.mass_kg, Eigen::Vector3d(l.com_m(), 0, 0), l.inertia_kgm2());
    };
    auto segment = [&](const std::string& name, int site, const SegmentParams& s) {
      add(name, site, s.mass_kg, Eigen::Vector3d(s.com_from_proximal_m, 0, 0), s.inertia_kgm2());
    };
    link("exo_upper_arm", 0, spec.exo.upper_link);
    if (spec.include_user_arm) segment("user_upper_arm", 0, spec.user.upper_arm);
    link("exo_forearm", 1, spec.exo.forearm_link);
    if (spec.include_user_arm) segment("user_forearm", 1, spec.user.forearm);
    link("exo_hand", 2, spec.exo.hand_piece);
    if (spec.include_user_arm) segment("user_hand", 2, spec.user.hand);
    // The payload: a steel sphere held in the hand, its centre at the hand's COM.
    const double radius_m = std::cbrt(3.0 * spec.payload_kg / (4.0 * std::numbers::pi * kSteelDensity_kg_per_m3));
    add("payload", 2, spec.payload_kg, Eigen::Vector3d(spec.user.hand.com_from_proximal_m, 0, 0),
        Eigen::Matrix3d::Identity() * (0.4 * spec.payload_kg * radius_m * radius_m));
  }
  m.gravity_mps2 = 9.81;
  check_tree(m);
  return m;
}

std::vector<JointRange> exoskeleton_joint_ranges(const ExoskeletonSpec& spec) {
  std::vector<JointRange> out;
  for (std::size_t k = 0; k < spec.sides.size(); ++k) {
    for (const ArmJointSpec& s : spec.arm_joints) {
      out.push_back({s.min_angle_rad, s.max_angle_rad, s.locked, s.locked_at_rad, s.damping_Nms_per_rad});
    }
  }
  return out;
}

std::vector<ArmJointSpec> read_arm_joints(config::Map& map) {
  std::vector<ArmJointSpec> out;
  for (config::Map item : map.maps("arm_joints", 1, 8)) {
    ArmJointSpec j;
    j.name = item.string("name");
    j.parent = item.string("parent");
    if (j.parent == "shoulder") j.parent.clear();
    const std::string site = item.choice("site", {"shoulder", "elbow", "wrist"});
    j.site = site == "shoulder" ? JointSite::kShoulder : site == "elbow" ? JointSite::kElbow : JointSite::kWrist;
    const std::vector<double> axis = item.numbers("axis", {-1.0, 1.0}, 3, 3);
    j.axis = Eigen::Vector3d(axis[0], axis[1], axis[2]);
    if (std::abs(j.axis.norm() - 1.0) > 1e-9) item.fail("axis", fmt::format("must be a unit vector, found length {:.6g}", j.axis.norm()));
    j.active = !item.boolean_or("passive", false);
    const std::vector<double> range = item.numbers("range_deg", {-180.0, 180.0}, 2, 2);
    if (!(range[0] < range[1])) item.fail("range_deg", fmt::format("needs min < max, found [{}, {}]", range[0], range[1]));
    j.min_angle_rad = deg_to_rad(range[0]);
    j.max_angle_rad = deg_to_rad(range[1]);
    if (item.has("locked_deg")) {
      j.locked = true;
      j.locked_at_rad = deg_to_rad(item.number("locked_deg", {range[0], range[1]}));
    }
    j.damping_Nms_per_rad = item.number_or("damping_Nms_per_rad", j.damping_Nms_per_rad, {0.0, 100.0});
    item.finish();
    out.push_back(j);
  }
  try {
    check_arm(out);
  } catch (const std::invalid_argument& e) {
    map.fail("arm_joints", e.what());
  }
  return out;
}

ArmModel ExoskeletonSpec::model() const { return build_exoskeleton_model(*this); }

namespace {

/// user{...}, exoskeleton{...}, payload_kg, include_user_arm of `map` (the caller finishes it).
void read_wearer_and_links(config::Map& map, ExoskeletonSpec& s) {
  s.user_spec = read_user(map.map("user"));
  s.user = s.user_spec.arm();
  config::Map exo = map.map("exoskeleton");
  s.shoulder_width_m = exo.number_or("shoulder_width_m", 0.0, {0.0, 1.0});
  if (s.sides.size() > 1 && !(s.shoulder_width_m > 0)) {
    exo.fail("shoulder_width_m", "two arms need the distance between their shoulder centres (> 0)");
  }
  s.exo = read_exo_arm(exo, s.user);
  s.payload_kg = map.number("payload_kg", {0.0, 20.0});
  s.include_user_arm = map.boolean("include_user_arm");
}

}  // namespace

BodyConfig read_body(const config::Document& doc) {
  config::Map root = doc.root();
  BodyConfig c;
  // The user first: `sides: dominant` is the side of their handedness.
  const UserSpec user = read_user(root.map("user"));
  c.controller.sides = read_sides(root, user);
  c.controller.arm_joints = read_arm_joints(root);
  c.plant.sides = c.controller.sides;
  c.plant.arm_joints = c.controller.arm_joints;
  read_wearer_and_links(root, c.controller);
  config::Map plant = root.map("plant");
  read_wearer_and_links(plant, c.plant);
  plant.finish();
  root.finish();
  return c;
}

std::vector<ArmSide> read_sides(config::Map& map, const UserSpec& user) {
  const std::string s = map.choice("sides", {"right", "left", "both", "dominant"});
  if (s == "both") return {ArmSide::kRight, ArmSide::kLeft};
  if (s == "dominant") return {user.left_handed ? ArmSide::kLeft : ArmSide::kRight};
  return {s == "right" ? ArmSide::kRight : ArmSide::kLeft};
}

}  // namespace peha::models
