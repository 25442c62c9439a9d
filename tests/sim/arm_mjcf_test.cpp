#include "peha/sim/arm_mjcf.hpp"

#include "peha/models/anthropometry.hpp"
#include "peha/models/units.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

namespace peha::sim {
namespace {

using models::ArmModel;
constexpr double kPi = std::numbers::pi;
constexpr double kTol = 1e-9;

ArmModel default_arm(double payload_kg = 5.0, bool user = true) {
  const auto u = models::user_arm_from_anthropometry(1.75, 70.0);
  return models::build_arm_model(models::exo_arm_for_user(u), u, payload_kg, user);
}

/// World COM of every body per the ArmModel's documented semantics (arm.hpp), independent of
/// MuJoCo and of models::forward_kinematics.
std::vector<Eigen::Vector3d> world_coms(const ArmModel& m, const Eigen::VectorXd& q) {
  std::vector<Eigen::Matrix3d> R(m.joints.size());
  std::vector<Eigen::Vector3d> p(m.joints.size());
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    const Eigen::Matrix3d Rp = i == 0 ? Eigen::Matrix3d::Identity() : R[i - 1];
    const Eigen::Vector3d pp = i == 0 ? Eigen::Vector3d::Zero() : p[i - 1];
    p[i] = pp + Rp * m.joints[i].offset_m;
    R[i] = Rp * Eigen::AngleAxisd(q[static_cast<Eigen::Index>(i)], m.joints[i].axis).toRotationMatrix();
  }
  std::vector<Eigen::Vector3d> c;
  for (const auto& b : m.bodies) c.push_back(p[b.joint] + R[b.joint] * b.com_m);
  return c;
}

struct Sim {
  ModelPtr m;
  DataPtr d;
  explicit Sim(const ArmModel& model, const ArmMjcfOptions& o = ArmMjcfOptions{})
      : m(load_arm_mjcf(arm_mjcf(model, o))), d(mj_makeData(m.get())) {}
  /// Gravity bias at zero velocity (the torques that hold the arm still).
  Eigen::VectorXd bias(const Eigen::VectorXd& q) {
    for (int i = 0; i < m->nq; ++i) d->qpos[i] = q[i];
    for (int i = 0; i < m->nv; ++i) d->qvel[i] = 0;
    mj_forward(m.get(), d.get());
    return Eigen::Map<const Eigen::VectorXd>(d->qfrc_bias, m->nv);
  }
};

Eigen::VectorXd posture(double sfe, double efe, double wfe = 0, double wr = 0, double waa = 0) {
  Eigen::VectorXd q(5);
  q << sfe, efe, wfe, wr, waa;
  return q;
}

TEST(ArmMjcf, LoadsWithTheModelsJointsAndBodies) {
  const ArmModel arm = default_arm();
  const std::string xml = arm_mjcf(arm, arm_mjcf_options());
  EXPECT_NE(xml.find("angle=\"radian\""), std::string::npos);
  EXPECT_NE(xml.find("contype=\"0\" conaffinity=\"0\""), std::string::npos);
  Sim s(arm, arm_mjcf_options());
  ASSERT_EQ(s.m->nv, 5);
  ASSERT_EQ(s.m->njnt, 5);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(mj_name2id(s.m.get(), mjOBJ_JOINT, models::kRightArmJointNames[i]), i);
    EXPECT_EQ(s.m->jnt_type[i], mjJNT_HINGE);
  }
  for (const auto& b : arm.bodies) {
    EXPECT_GE(mj_name2id(s.m.get(), mjOBJ_BODY, b.name.c_str()), 0) << b.name;
    EXPECT_GE(mj_name2id(s.m.get(), mjOBJ_SITE, (b.name + "_com").c_str()), 0) << b.name;
  }
  EXPECT_DOUBLE_EQ(s.m->opt.timestep, 0.0005);
  EXPECT_DOUBLE_EQ(s.m->opt.gravity[2], -9.81);
  // Options reach the joints; R_WR is clamped by an equality constraint (nv stays 5).
  EXPECT_NEAR(s.m->jnt_range[2 * models::kEFE + 1], models::deg_to_rad(135.0), 1e-12);
  EXPECT_DOUBLE_EQ(s.m->dof_damping[models::kWAA], 0.05);
  EXPECT_EQ(s.m->neq, 1);
  for (int g = 0; g < s.m->ngeom; ++g) {
    EXPECT_EQ(s.m->geom_contype[g], 0);
    EXPECT_EQ(s.m->geom_conaffinity[g], 0);
  }
}

TEST(ArmMjcf, MassesComsAndInertiasEqualTheArmModel) {
  const ArmModel arm = default_arm();
  Sim s(arm);
  for (const Eigen::VectorXd& q : {posture(0, 0), posture(-kPi / 2, 0), posture(0.3, 1.1, -0.4, 0.5, 0.2)}) {
    s.bias(q);
    const auto coms = world_coms(arm, q);
    double total = 0;
    for (std::size_t k = 0; k < arm.bodies.size(); ++k) {
      const auto& b = arm.bodies[k];
      const int id = mj_name2id(s.m.get(), mjOBJ_BODY, b.name.c_str());
      ASSERT_GE(id, 0);
      EXPECT_NEAR(s.m->body_mass[id], b.mass_kg, kTol) << b.name;
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.d->xipos[3 * id + a], coms[k][a], kTol) << b.name;
      // Inertia in the joint frame: iquat * diag(body_inertia) * iquat^T.
      Eigen::Matrix3d R;
      mjtNum mat[9];
      mju_quat2Mat(mat, s.m->body_iquat + 4 * id);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = mat[3 * r + c];
      const Eigen::Vector3d principal(s.m->body_inertia[3 * id], s.m->body_inertia[3 * id + 1],
                                      s.m->body_inertia[3 * id + 2]);
      const Eigen::Matrix3d I = R * principal.asDiagonal() * R.transpose();
      EXPECT_LT((I - b.inertia_kgm2).cwiseAbs().maxCoeff(), 1e-12) << b.name;
      total += b.mass_kg;
    }
    double mj_total = 0;
    for (int i = 0; i < s.m->nbody; ++i) mj_total += s.m->body_mass[i];
    EXPECT_NEAR(mj_total, total, kTol);
    EXPECT_NEAR(mj_total, 3.9 + 3.5 + 5.0, kTol);
  }
}

// Gravity bias against hand computations. At q = 0 the arm points forward horizontally: every
// joint's torque is g times the mass beyond it times the horizontal lever. Hanging down
// (-pi/2, 0, ...), nothing needs holding. With the upper arm down and the elbow at 90 deg, the
// shoulder and the elbow hold the same forearm-and-beyond moment.
TEST(ArmMjcf, GravityBiasMatchesHandComputation) {
  const ArmModel arm = default_arm();
  Sim s(arm);
  const double g = 9.81;
  const double Lu = arm.joints[models::kEFE].offset_m.x(), Lf = arm.joints[models::kWFE].offset_m.x();

  double sfe = 0, efe = 0, wfe = 0;
  for (const auto& b : arm.bodies) {
    const double x = b.com_m.x() + (b.joint >= models::kEFE ? Lu : 0) + (b.joint >= models::kWFE ? Lf : 0);
    sfe += b.mass_kg * g * x;
    if (b.joint >= models::kEFE) efe += b.mass_kg * g * (x - Lu);
    if (b.joint >= models::kWFE) wfe += b.mass_kg * g * (x - Lu - Lf);
  }
  const Eigen::VectorXd horizontal = s.bias(posture(0, 0));
  EXPECT_NEAR(horizontal[models::kSFE], sfe, kTol);
  EXPECT_NEAR(horizontal[models::kEFE], efe, kTol);
  EXPECT_NEAR(horizontal[models::kWFE], wfe, kTol);
  EXPECT_NEAR(horizontal[models::kWR], 0.0, kTol);
  EXPECT_NEAR(horizontal[models::kWAA], 0.0, kTol);
  // Positive: the flexors hold the arm up. Magnitude check for the doc's numbers.
  EXPECT_GT(sfe, 50.0);
  EXPECT_LT(sfe, 100.0);  // below the shoulder's 100 Nm peak (paper)

  const Eigen::VectorXd hanging = s.bias(posture(-kPi / 2, 0));
  EXPECT_LT(hanging.cwiseAbs().maxCoeff(), kTol);

  const Eigen::VectorXd elbow90 = s.bias(posture(-kPi / 2, kPi / 2));
  EXPECT_NEAR(elbow90[models::kSFE], efe, kTol);
  EXPECT_NEAR(elbow90[models::kEFE], efe, kTol);
}

// One body at a known COM: tau = m g * horizontal lever, at any angle.
TEST(ArmMjcf, SingleBodyLever) {
  ArmModel m;
  m.joints = {{"hinge", {0, 0, 1.0}, {0, -1, 0}, true}};
  m.bodies = {{"bob", 0, 2.0, {0.3, 0, 0}, Eigen::Vector3d(0.001, 0.01, 0.01).asDiagonal()}};
  Sim s(m);
  for (double q : {0.0, 0.4, -1.2, kPi / 2}) {
    Eigen::VectorXd qv(1);
    qv << q;
    EXPECT_NEAR(s.bias(qv)[0], 2.0 * 9.81 * 0.3 * std::cos(q), kTol) << q;
  }
}

// An off-diagonal inertia (principal axes + diaginertia) arrives intact; joints at one point share
// one MuJoCo body.
TEST(ArmMjcf, FullInertiaAndGroupedJoints) {
  ArmModel m;
  m.joints = {{"a", {0, 0, 0}, {0, -1, 0}, true},
              {"b", {0, 0, 0}, {1, 0, 0}, false},
              {"c", {0.2, 0, 0}, {0, 0, 1}, false}};
  Eigen::Matrix3d I;
  I << 0.02, 0.001, -0.002, 0.001, 0.03, 0.0005, -0.002, 0.0005, 0.025;
  m.bodies = {{"one", 1, 1.5, {0.1, 0.01, -0.02}, I}, {"two", 2, 0.7, {0.05, 0.02, 0.0}, I * 0.5}};
  const std::string xml = arm_mjcf(m, ArmMjcfOptions{});
  EXPECT_NE(xml.find("quat="), std::string::npos);
  EXPECT_EQ(xml.find("b_frame"), std::string::npos);  // "b" joined "a"'s body
  Sim s(m);
  EXPECT_EQ(s.m->nv, 3);
  const Eigen::Vector3d q(0.3, -0.7, 0.9);
  s.bias(q);
  const auto coms = world_coms(m, q);
  for (std::size_t k = 0; k < m.bodies.size(); ++k) {
    const int id = mj_name2id(s.m.get(), mjOBJ_BODY, m.bodies[k].name.c_str());
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.d->xipos[3 * id + a], coms[k][a], kTol);
    Eigen::Matrix3d R;
    mjtNum mat[9];
    mju_quat2Mat(mat, s.m->body_iquat + 4 * id);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R(r, c) = mat[3 * r + c];
    const Eigen::Vector3d p(s.m->body_inertia[3 * id], s.m->body_inertia[3 * id + 1], s.m->body_inertia[3 * id + 2]);
    EXPECT_LT((R * p.asDiagonal() * R.transpose() - m.bodies[k].inertia_kgm2).cwiseAbs().maxCoeff(), 1e-14);
  }
}

TEST(ArmMjcf, ZeroPayloadAndNoUserArmLoad) {
  const ArmModel bare = default_arm(0.0, false);
  Sim s(bare, arm_mjcf_options());
  const int id = mj_name2id(s.m.get(), mjOBJ_BODY, "payload");
  ASSERT_GE(id, 0);
  EXPECT_EQ(s.m->body_mass[id], 0.0);
  double total = 0;
  for (int i = 0; i < s.m->nbody; ++i) total += s.m->body_mass[i];
  EXPECT_NEAR(total, 3.9, kTol);
}

TEST(ArmMjcf, RejectsBadInput) {
  ArmModel arm = default_arm();
  ArmMjcfOptions o = arm_mjcf_options();
  o.joints.pop_back();
  EXPECT_THROW(arm_mjcf(arm, o), std::invalid_argument);
  o = arm_mjcf_options();
  o.joints[0].range_min_rad = o.joints[0].range_max_rad;
  EXPECT_THROW(arm_mjcf(arm, o), std::invalid_argument);
  o = ArmMjcfOptions{};
  o.timestep_s = 0;
  EXPECT_THROW(arm_mjcf(arm, o), std::invalid_argument);
  ArmModel bad = arm;
  bad.joints[1].name = "R EFE\"";
  EXPECT_THROW(arm_mjcf(bad, ArmMjcfOptions{}), std::invalid_argument);
  bad = arm;
  bad.bodies[0].com_m.x() = std::nan("");
  EXPECT_THROW(arm_mjcf(bad, ArmMjcfOptions{}), std::invalid_argument);
  // A moving frame that carries nothing (the wrist frames without any body).
  bad = arm;
  std::erase_if(bad.bodies, [](const models::ArmBody& b) { return b.joint == models::kWAA; });
  EXPECT_THROW(arm_mjcf(bad, ArmMjcfOptions{}), std::invalid_argument);
  // MuJoCo's own errors arrive as runtime_error.
  EXPECT_THROW(load_arm_mjcf("<mujoco><worldbody><body><joint/></body></worldbody></mujoco>"), std::runtime_error);
}

TEST(ArmMjcf, LeavesNoTemporaryFiles) {
  const auto dir = std::filesystem::temp_directory_path();
  // Only this process's files: CTest runs other tests (which load arm models too) in parallel.
  const std::string mine = "peha_arm_mjcf_" + std::to_string(static_cast<long>(::getpid())) + "_";
  auto count = [&] {
    int n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.path().filename().string().rfind(mine, 0) == 0) ++n;
    }
    return n;
  };
  const int before = count();
  { Sim s(default_arm()); }
  EXPECT_THROW(load_arm_mjcf("<mujoco><bogus/></mujoco>"), std::runtime_error);
  EXPECT_EQ(count(), before);
}

}  // namespace
}  // namespace peha::sim
