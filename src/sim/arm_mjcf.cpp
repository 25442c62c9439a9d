#include "peha/sim/arm_mjcf.hpp"

#include "peha/models/exoskeleton.hpp"

#include <fmt/format.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>

#include <unistd.h>

namespace peha::sim {
namespace {

/// Shortest text that reads back to the same double.
std::string num(double v) {
  if (v == 0.0) return "0";  // also turns -0 into 0
  return fmt::format("{}", v);
}

std::string vec(const Eigen::Vector3d& v) { return fmt::format("{} {} {}", num(v.x()), num(v.y()), num(v.z())); }

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("arm_mjcf: " + what);
}

void check_name(const std::string& name, const char* kind) {
  require(!name.empty(), fmt::format("a {} has an empty name", kind));
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    require(ok, fmt::format("{} name '{}' may only contain letters, digits, '_', '-' and '.'", kind, name));
  }
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

void check_model(const models::ArmModel& model) {
  require(model.dof() > 0, "the model has no joints");
  require(std::isfinite(model.gravity_mps2) && model.gravity_mps2 >= 0, "gravity_mps2 must be finite and >= 0");
  try {
    models::check_tree(model);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("arm_mjcf: ") + e.what());
  }
  for (const auto& j : model.joints) {
    check_name(j.name, "joint");
    require(finite(j.offset_m), fmt::format("joint '{}' has a non-finite offset", j.name));
    require(finite(j.axis) && std::abs(j.axis.norm() - 1.0) < 1e-9,
            fmt::format("joint '{}' needs a unit axis", j.name));
  }
  for (const auto& b : model.bodies) {
    check_name(b.name, "body");
    require(b.joint >= 0 && b.joint < model.dof(),
            fmt::format("body '{}' hangs on joint {} of a {}-joint model", b.name, b.joint, model.dof()));
    require(std::isfinite(b.mass_kg) && b.mass_kg >= 0, fmt::format("body '{}' needs a mass >= 0", b.name));
    require(finite(b.com_m) && b.inertia_kgm2.allFinite(), fmt::format("body '{}' has non-finite values", b.name));
    require((b.inertia_kgm2 - b.inertia_kgm2.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * (1 + b.inertia_kgm2.norm()),
            fmt::format("body '{}' has a non-symmetric inertia", b.name));
  }
}

void check_joint_options(const ArmMjcfJoint& o, const std::string& joint) {
  require(std::isfinite(o.range_min_rad) && std::isfinite(o.range_max_rad) && o.range_min_rad < o.range_max_rad,
          fmt::format("joint '{}': range must be finite with min < max", joint));
  require(std::isfinite(o.damping_Nms_per_rad) && o.damping_Nms_per_rad >= 0,
          fmt::format("joint '{}': damping must be >= 0", joint));
  require(std::isfinite(o.armature_kgm2) && o.armature_kgm2 >= 0, fmt::format("joint '{}': armature must be >= 0", joint));
  require(std::isfinite(o.stiffness_Nm_per_rad) && o.stiffness_Nm_per_rad >= 0 && std::isfinite(o.spring_ref_rad),
          fmt::format("joint '{}': stiffness must be >= 0 and spring_ref finite", joint));
  require(std::isfinite(o.locked_at_rad), fmt::format("joint '{}': locked_at_rad must be finite", joint));
}

/// The MuJoCo bodies' first joints: joint i joins its parent's body when it is listed right after
/// it, sits at its origin (zero offset), is its only child and no ArmBody hangs on the parent
/// (MuJoCo chains the joints of one body in order, exactly like our serial chain).
std::vector<bool> starts_body(const models::ArmModel& model) {
  std::vector<bool> carries(model.joints.size(), false);
  for (const auto& b : model.bodies) carries[b.joint] = true;
  std::vector<int> children(model.joints.size(), 0);
  for (int i = 0; i < model.dof(); ++i) {
    if (model.parent(i) >= 0) ++children[static_cast<std::size_t>(model.parent(i))];
  }
  std::vector<bool> starts(model.joints.size(), true);
  for (int i = 1; i < model.dof(); ++i) {
    const auto parent = static_cast<std::size_t>(model.parent(i));
    starts[static_cast<std::size_t>(i)] = !(model.parent(i) == i - 1 && children[parent] == 1 &&
                                            model.joints[static_cast<std::size_t>(i)].offset_m.isZero(0.0) && !carries[parent]);
  }
  return starts;
}

void indent(std::string& out, int depth) { out.append(static_cast<std::size_t>(2 * depth), ' '); }

void write_body(std::string& out, int depth, const models::ArmBody& b, double geom_radius_m) {
  indent(out, depth);
  out += fmt::format("<body name=\"{}\">\n", b.name);
  const Eigen::Matrix3d& I = b.inertia_kgm2;
  if (b.mass_kg > 0) {
    indent(out, depth + 1);
    if (I(0, 1) == 0 && I(0, 2) == 0 && I(1, 2) == 0) {
      out += fmt::format("<inertial pos=\"{}\" mass=\"{}\" diaginertia=\"{} {} {}\"/>\n", vec(b.com_m), num(b.mass_kg),
                         num(I(0, 0)), num(I(1, 1)), num(I(2, 2)));
    } else {
      // A full tensor: diagonalised here rather than with fullinertia="ixx iyy izz ixy ixz iyz",
      // because MuJoCo 2.2.2 diagonalises that with an iterative solver good to ~1e-8 relative;
      // Eigen's is good to machine precision, and MuJoCo takes quat + diaginertia as given.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(I);
      Eigen::Matrix3d R = eig.eigenvectors();
      if (R.determinant() < 0) R.col(2) = -R.col(2);
      const Eigen::Quaterniond quat(R);
      const Eigen::Vector3d principal = eig.eigenvalues();
      out += fmt::format("<inertial pos=\"{}\" mass=\"{}\" quat=\"{} {} {} {}\" diaginertia=\"{} {} {}\"/>\n",
                         vec(b.com_m), num(b.mass_kg), num(quat.w()), num(quat.x()), num(quat.y()), num(quat.z()),
                         num(principal.x()), num(principal.y()), num(principal.z()));
    }
  }
  // Visual geom (its mass is ignored: the <inertial> above is explicit). An elongated body is a
  // capsule from the joint origin through its COM; anything else a sphere at the COM.
  const double spread = I.diagonal().maxCoeff() - I.diagonal().minCoeff();
  indent(out, depth + 1);
  if (b.com_m.norm() > 1e-6 && spread > 1e-3 * I.diagonal().maxCoeff()) {
    out += fmt::format("<geom name=\"{}_geom\" type=\"capsule\" fromto=\"0 0 0 {}\" size=\"{}\" mass=\"{}\"/>\n", b.name,
                       vec(2.0 * b.com_m), num(geom_radius_m), num(b.mass_kg));
  } else {
    const double r = b.mass_kg > 0 ? std::sqrt(2.5 * I.trace() / 3.0 / b.mass_kg) : 0.0;
    out += fmt::format("<geom name=\"{}_geom\" type=\"sphere\" pos=\"{}\" size=\"{}\" mass=\"{}\"/>\n", b.name,
                       vec(b.com_m), num(r > 1e-3 ? r : geom_radius_m), num(b.mass_kg));
  }
  indent(out, depth + 1);
  out += fmt::format("<site name=\"{}_com\" pos=\"{}\"/>\n", b.name, vec(b.com_m));
  indent(out, depth);
  out += "</body>\n";
}

}  // namespace

ArmMjcfOptions exoskeleton_mjcf_options(const models::ExoskeletonSpec& spec) {
  ArmMjcfOptions o;
  o.model_name = spec.sides.size() > 1 ? "peha_upper_body" : fmt::format("peha_{}_arm", spec.sides.at(0) == models::ArmSide::kRight ? "right" : "left");
  for (const models::JointRange& r : models::exoskeleton_joint_ranges(spec)) {
    o.joints.push_back({r.min_rad, r.max_rad, r.damping_Nms_per_rad, 0.0, 0.0, 0.0, r.locked, r.locked_at_rad});
  }
  return o;
}

ArmMjcfOptions arm_mjcf_options() {
  models::ExoskeletonSpec spec;
  spec.arm_joints = models::paper_right_arm_joints();
  return exoskeleton_mjcf_options(spec);
}

std::string arm_mjcf(const models::ArmModel& model, const ArmMjcfOptions& options) {
  check_model(model);
  check_name(options.model_name, "model");
  require(std::isfinite(options.timestep_s) && options.timestep_s > 0 && options.timestep_s <= 0.1,
          "timestep_s must be in (0, 0.1]");
  require(options.integrator == "Euler" || options.integrator == "RK4" || options.integrator == "implicit",
          fmt::format("integrator '{}' is not one of Euler, RK4, implicit", options.integrator));
  require(std::isfinite(options.geom_radius_m) && options.geom_radius_m > 0, "geom_radius_m must be > 0");
  require(options.joints.empty() || options.joints.size() == model.joints.size(),
          fmt::format("{} joint options for a {}-joint model", options.joints.size(), model.joints.size()));
  auto joint_options = [&](std::size_t i) -> const ArmMjcfJoint& {
    return options.joints.empty() ? options.default_joint : options.joints[i];
  };
  for (std::size_t i = 0; i < model.joints.size(); ++i) check_joint_options(joint_options(i), model.joints[i].name);

  const std::vector<bool> starts = starts_body(model);
  // MuJoCo refuses a moving body without mass unless a welded child carries some: every body we
  // open must end with a joint that carries a massive ArmBody.
  for (std::size_t i = 0; i < model.joints.size(); ++i) {
    const bool last_of_body = i + 1 == model.joints.size() || starts[i + 1];  // a joined child follows its parent
    if (!last_of_body) continue;
    bool massive = false;
    for (const auto& b : model.bodies) {
      if (b.joint == static_cast<int>(i) && b.mass_kg > 0 && b.inertia_kgm2.diagonal().minCoeff() > 0) massive = true;
    }
    require(massive, fmt::format("joint '{}' moves no body with positive mass and inertia; MuJoCo cannot "
                                 "simulate a massless moving body",
                                 model.joints[i].name));
  }

  std::string out;
  out += fmt::format(
      "<!-- Generated by peha::sim::arm_mjcf from a models::ArmModel ({} joints, {} bodies); do not edit.\n"
      "     One MuJoCo body per joint group (\"<joint>_frame\"), each ArmBody a welded child with an explicit\n"
      "     <inertial> and a site \"<body>_com\". Angles in rad, SI units. See docs/right-arm.md. -->\n",
      model.joints.size(), model.bodies.size());
  out += fmt::format("<mujoco model=\"{}\">\n", options.model_name);
  out += "  <compiler angle=\"radian\" autolimits=\"true\"/>\n";
  // Nothing collides (contype = conaffinity = 0 below): the contact flag off skips MuJoCo's collision
  // detection every step (a quarter of the arm's mj_step), which could only ever find nothing.
  out += fmt::format("  <option timestep=\"{}\" gravity=\"0 0 {}\" integrator=\"{}\">\n    <flag contact=\"disable\"/>\n  </option>\n",
                     num(options.timestep_s), num(-model.gravity_mps2), options.integrator);
  // The cables' stiction is MuJoCo's frictionloss constraint (set each step by the plant). It must be
  // stiff: with MuJoCo's default softness a load below the friction bound still creeps (the elbow slid
  // 1.5 deg/s at a third of its stiction band). Same values as models/one_dof_rig.xml.
  out += "  <default>\n    <geom contype=\"0\" conaffinity=\"0\"/>\n"
         "    <joint solreffriction=\"0.0005 1\" solimpfriction=\"0.99 0.999 0.001\"/>\n  </default>\n";
  out += "  <worldbody>\n";

  // Depth-first: a joint's body holds its joint, its welded ArmBodies and its children's bodies.
  std::vector<std::vector<int>> children(model.joints.size());
  for (int i = 0; i < model.dof(); ++i) {
    if (model.parent(i) >= 0) children[static_cast<std::size_t>(model.parent(i))].push_back(i);
  }
  auto write_joint = [&](auto&& self, int i, int depth) -> void {
    const auto& j = model.joints[static_cast<std::size_t>(i)];
    const bool opens = starts[static_cast<std::size_t>(i)];
    if (opens) {
      indent(out, depth);
      out += fmt::format("<body name=\"{}_frame\" pos=\"{}\">\n", j.name, vec(j.offset_m));
      ++depth;
    }
    const ArmMjcfJoint& o = joint_options(static_cast<std::size_t>(i));
    indent(out, depth);
    out += fmt::format(
        "<joint name=\"{}\" type=\"hinge\" pos=\"0 0 0\" axis=\"{}\" limited=\"true\" range=\"{} {}\" damping=\"{}\" "
        "armature=\"{}\" stiffness=\"{}\" springref=\"{}\"/>\n",
        j.name, vec(j.axis), num(o.range_min_rad), num(o.range_max_rad), num(o.damping_Nms_per_rad),
        num(o.armature_kgm2), num(o.stiffness_Nm_per_rad), num(o.spring_ref_rad));
    for (const auto& b : model.bodies) {
      if (b.joint == i) write_body(out, depth, b, options.geom_radius_m);
    }
    for (int c : children[static_cast<std::size_t>(i)]) self(self, c, depth);
    if (opens) {
      --depth;
      indent(out, depth);
      out += "</body>\n";
    }
  };
  for (int i = 0; i < model.dof(); ++i) {
    if (model.parent(i) < 0) write_joint(write_joint, i, 2);
  }
  out += "  </worldbody>\n";

  bool any_locked = false;
  for (std::size_t i = 0; i < model.joints.size(); ++i) any_locked = any_locked || joint_options(i).locked;
  if (any_locked) {
    out += "  <equality>\n";
    for (std::size_t i = 0; i < model.joints.size(); ++i) {
      const ArmMjcfJoint& o = joint_options(i);
      if (!o.locked) continue;
      out += fmt::format("    <joint name=\"{}_lock\" joint1=\"{}\" polycoef=\"{} 0 0 0 0\"/>\n", model.joints[i].name,
                         model.joints[i].name, num(o.locked_at_rad));
    }
    out += "  </equality>\n";
  }
  out += "</mujoco>\n";
  return out;
}

ModelPtr load_arm_mjcf(const std::string& xml) {
  static std::atomic<unsigned> counter{0};
  std::random_device rd;
  const auto path = std::filesystem::temp_directory_path() /
                    fmt::format("peha_arm_mjcf_{}_{}_{:08x}.xml", static_cast<long>(::getpid()), counter++, rd());
  struct Remove {
    std::filesystem::path p;
    ~Remove() {
      std::error_code ec;
      std::filesystem::remove(p, ec);
    }
  } remove{path};
  {
    std::ofstream f(path);
    if (!f) throw std::runtime_error(fmt::format("{}: cannot write the temporary MJCF file", path.string()));
    f << xml;
    f.close();
    if (!f) throw std::runtime_error(fmt::format("{}: writing the temporary MJCF file failed", path.string()));
  }
  return load_mjcf(path);
}

}  // namespace peha::sim
