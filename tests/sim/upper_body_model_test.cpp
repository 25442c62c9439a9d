// The exoskeleton described as data (models/exoskeleton.hpp): the shipped upper body (both arms,
// shoulder abduction + flexion, elbow, wrist) read from configs/arm/upper_body_body.yaml, its left
// arm the mirror image of its right, its gravity and dynamics against MuJoCo's on the generated MJCF,
// and the description's checks.

#include "peha/models/exoskeleton.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "../support/replaced.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

namespace peha {
namespace {


models::BodyConfig upper_body() {
  return models::read_body(config::Document::load_file(PEHA_SOURCE_DIR "/configs/arm/upper_body_body.yaml"));
}

int joint_index(const models::ArmModel& m, const std::string& name) {
  for (int i = 0; i < m.dof(); ++i) {
    if (m.joints[static_cast<std::size_t>(i)].name == name) return i;
  }
  ADD_FAILURE() << "no joint " << name;
  return -1;
}

// The side prefix comes off joint and body names alike, and only a side prefix does.
TEST(UpperBody, WithoutSideStripsOnlyTheSidePrefix) {
  EXPECT_EQ(models::without_side("R_SFE"), "SFE");
  EXPECT_EQ(models::without_side("L_exo_forearm"), "exo_forearm");
  EXPECT_EQ(models::without_side("exo_forearm"), "exo_forearm");  // a one-armed body's bodies
  EXPECT_EQ(models::without_side("SFE"), "SFE");
  EXPECT_EQ(models::without_side("R_"), "R_");
  EXPECT_EQ(models::without_side("RX_SFE"), "RX_SFE");
}

TEST(UpperBody, ShippedFileBuildsBothArmsWithPrefixedJointsAndBodies) {
  const models::BodyConfig c = upper_body();
  const models::ArmModel m = c.controller.model();
  ASSERT_EQ(m.dof(), 12);
  EXPECT_EQ(m.joints[0].name, "R_SAA");
  EXPECT_EQ(m.joints[6].name, "L_SAA");
  EXPECT_EQ(m.parent(6), -1);                           // each arm hangs on the world
  EXPECT_EQ(m.parent(joint_index(m, "L_EFE")), joint_index(m, "L_SFE"));
  EXPECT_NEAR(m.joints[0].offset_m.y(), -0.19, 1e-12);  // right shoulder at -w/2
  EXPECT_NEAR(m.joints[6].offset_m.y(), 0.19, 1e-12);
  EXPECT_TRUE(m.joints[6].axis.isApprox(Eigen::Vector3d(1, 0, 0)));  // abduction mirrored: -M(-x) = +x
  EXPECT_TRUE(m.joints[7].axis.isApprox(Eigen::Vector3d(0, -1, 0))); // flexion unchanged
  int right = 0, left = 0;
  for (const models::ArmBody& b : m.bodies) {
    right += b.name.starts_with("R_");
    left += b.name.starts_with("L_");
  }
  EXPECT_EQ(right, 7);
  EXPECT_EQ(left, 7);
  EXPECT_FALSE(m.joints[joint_index(m, "R_WR")].active);
  EXPECT_TRUE(m.joints[joint_index(m, "L_SAA")].active);
}

// The same angles on both arms are mirror-image postures: every joint carries the same gravity torque
// on both sides (1e-12 Nm), and every body's centre of mass is the other's mirror image.
TEST(UpperBody, LeftArmIsTheMirrorImageOfTheRight) {
  const models::ArmModel m = upper_body().plant.model();
  models::ArmData data(m);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> angle(-1.5, 1.5);
  for (int trial = 0; trial < 100; ++trial) {
    Eigen::VectorXd q(12);
    for (int i = 0; i < 6; ++i) q[i] = q[i + 6] = angle(rng);
    const Eigen::VectorXd tau = models::gravity_torque(m, data, q);
    for (int i = 0; i < 6; ++i) ASSERT_NEAR(tau[i], tau[i + 6], 1e-12) << "trial " << trial << " joint " << m.joints[i].name;
    for (std::size_t b = 0; b < 7; ++b) {
      const Eigen::Vector3d r = models::com_position(m, data, static_cast<int>(b));
      const Eigen::Vector3d l = models::com_position(m, data, static_cast<int>(b + 7));
      ASSERT_LT((Eigen::Vector3d(r.x(), -r.y(), r.z()) - l).norm(), 1e-12) << m.bodies[b].name;
    }
  }
  // A real arm: holding both arms out forward takes more shoulder torque than hanging them.
  Eigen::VectorXd forward = Eigen::VectorXd::Zero(12), hanging = forward;
  hanging[1] = hanging[7] = models::deg_to_rad(-90);
  EXPECT_GT(models::gravity_torque(m, data, forward)[1], 15.0);
  EXPECT_NEAR(models::gravity_torque(m, data, hanging)[1], 0.0, 1e-9);
}

// An asymmetric posture: what one arm does never loads the other's joints.
TEST(UpperBody, OneArmsPostureNeverLoadsTheOtherArm) {
  const models::ArmModel m = upper_body().controller.model();
  models::ArmData data(m);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(12);
  q << models::deg_to_rad(20), models::deg_to_rad(-30), models::deg_to_rad(80), models::deg_to_rad(10), 0, 0, 0, models::deg_to_rad(-90), 0, 0, 0, 0;
  const Eigen::VectorXd before = models::gravity_torque(m, data, q);
  q.tail(6) << models::deg_to_rad(60), models::deg_to_rad(10), models::deg_to_rad(120), models::deg_to_rad(-40), 0, models::deg_to_rad(5);
  const Eigen::VectorXd after = models::gravity_torque(m, data, q);
  EXPECT_EQ((after.head(6) - before.head(6)).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT((after.tail(6) - before.tail(6)).cwiseAbs().maxCoeff(), 1.0);
}

// The plant's upper body through the generated MJCF (joints unlocked and undamped): gravity equals
// qfrc_bias and recursive Newton-Euler equals mj_inverse at 100 random states, 1e-9 Nm.
TEST(UpperBody, GravityAndInverseDynamicsEqualMujocosOnTheGeneratedModel) {
  const models::BodyConfig c = upper_body();
  const models::ArmModel m = c.plant.model();
  sim::ArmMjcfOptions o = sim::exoskeleton_mjcf_options(c.plant);
  EXPECT_EQ(o.model_name, "peha_upper_body");
  for (sim::ArmMjcfJoint& j : o.joints) {
    j.locked = false;
    j.damping_Nms_per_rad = 0;
    j.range_min_rad = -4;
    j.range_max_rad = 4;
  }
  sim::ModelPtr mj = sim::load_arm_mjcf(sim::arm_mjcf(m, o));
  sim::DataPtr d(mj_makeData(mj.get()));
  ASSERT_EQ(mj->nv, 12);
  models::ArmData data(m);
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> angle(-2.0, 2.0), rate(-3.0, 3.0), accel(-20.0, 20.0);
  for (int trial = 0; trial < 100; ++trial) {
    Eigen::VectorXd q(12), qd(12), qdd(12);
    for (int i = 0; i < 12; ++i) {
      q[i] = d->qpos[i] = angle(rng);
      d->qvel[i] = 0;
    }
    mj_forward(mj.get(), d.get());
    const Eigen::VectorXd g = models::gravity_torque(m, data, q);
    for (int i = 0; i < 12; ++i) ASSERT_NEAR(g[i], d->qfrc_bias[i], 1e-9) << "trial " << trial << " " << m.joints[static_cast<std::size_t>(i)].name;
    for (int i = 0; i < 12; ++i) {
      qd[i] = d->qvel[i] = rate(rng);
      qdd[i] = d->qacc[i] = accel(rng);
    }
    mj_inverse(mj.get(), d.get());
    const Eigen::VectorXd& tau = models::inverse_dynamics(m, data, q, qd, qdd);
    for (int i = 0; i < 12; ++i) ASSERT_NEAR(tau[i], d->qfrc_inverse[i], 1e-9) << "trial " << trial << " " << m.joints[static_cast<std::size_t>(i)].name;
  }
}

// The shipped right arm, now read through the same description, is the paper's arm: five joints in the
// old order with the old bodies, and its MJCF options are the old ones.
TEST(UpperBody, TheRightArmIsTheSameDescriptionWithOneSide) {
  const models::BodyConfig c = models::read_body(config::Document::load_file(PEHA_SOURCE_DIR "/configs/arm/right_arm_body.yaml"));
  const models::ArmModel m = c.controller.model();
  const models::ArmModel paper = models::build_arm_model(c.controller.exo, c.controller.user, 0.0, true);
  ASSERT_EQ(m.dof(), paper.dof());
  for (int i = 0; i < m.dof(); ++i) {
    EXPECT_EQ(m.joints[static_cast<std::size_t>(i)].name, paper.joints[static_cast<std::size_t>(i)].name);
    EXPECT_EQ(m.parent(i), paper.parent(i));
    EXPECT_TRUE(m.joints[static_cast<std::size_t>(i)].offset_m.isApprox(paper.joints[static_cast<std::size_t>(i)].offset_m));
  }
  ASSERT_EQ(m.bodies.size(), paper.bodies.size());
  for (std::size_t b = 0; b < m.bodies.size(); ++b) EXPECT_EQ(m.bodies[b].name, paper.bodies[b].name);
  EXPECT_EQ(sim::arm_mjcf(m, sim::exoskeleton_mjcf_options(c.controller)), sim::arm_mjcf(paper, sim::arm_mjcf_options()));
}

std::string upper_body_text() {
  std::ifstream in(PEHA_SOURCE_DIR "/configs/arm/upper_body_body.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string read_error(const std::string& text) {
  try {
    models::read_body(config::Document::load_string(text, "upper_body_body.yaml"));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

using testing::replaced;

TEST(UpperBody, RejectsABadJointListNamingTheJoint) {
  const std::string text = upper_body_text();
  ASSERT_EQ(read_error(text), "");
  // A parent that is not listed before.
  const std::string later = read_error(replaced(text, "{name: EFE, parent: SFE", "{name: EFE, parent: WFE"));
  EXPECT_NE(later.find("'EFE' names parent 'WFE'"), std::string::npos) << later;
  // A joint at the shoulder after the elbow.
  const std::string back = read_error(replaced(text, "{name: WFE, parent: EFE, site: wrist", "{name: WFE, parent: EFE, site: shoulder"));
  EXPECT_NE(back.find("'WFE' at the shoulder cannot follow 'EFE' at the elbow"), std::string::npos) << back;
  // Two arms need their shoulders apart.
  const std::string narrow = read_error(replaced(text, "  shoulder_width_m: 0.38 ", "  shoulder_width_m: 0.0 "));
  EXPECT_NE(narrow.find("shoulder_width_m"), std::string::npos) << narrow;
  // A non-unit axis.
  const std::string axis = read_error(replaced(text, "axis: [-1, 0, 0]", "axis: [-1, 1, 0]"));
  EXPECT_NE(axis.find("unit vector"), std::string::npos) << axis;
  // Unknown side, unknown key in a joint.
  EXPECT_NE(read_error(replaced(text, "\nsides: both", "\nsides: three")), "");
  EXPECT_NE(read_error(replaced(text, "passive: true}", "passive: true, colour: red}")).find("colour"), std::string::npos);
}

TEST(UpperBody, DominantSideFollowsHandednessAndSexChoosesTheTable) {
  std::string text = replaced(upper_body_text(), "\nsides: both", "\nsides: dominant");
  text = replaced(text, "handedness: right", "handedness: left");
  const models::ArmModel left = models::read_body(config::Document::load_string(text, "b.yaml")).controller.model();
  ASSERT_EQ(left.dof(), 6);
  EXPECT_EQ(left.joints[0].name, "L_SAA");
  EXPECT_EQ(left.bodies[0].name, "exo_upper_arm");  // one arm: plain body names

  // de Leva (1996): a woman's forearm carries 1.38 % of body mass, a man's 1.62 %; Winter's 1.6 %.
  const models::UserArm male = models::user_arm_from_anthropometry(1.75, 70, models::Sex::kMale);
  const models::UserArm female = models::user_arm_from_anthropometry(1.75, 70, models::Sex::kFemale);
  const models::UserArm neutral = models::user_arm_from_anthropometry(1.75, 70);
  EXPECT_NEAR(male.forearm.mass_kg, 0.0162 * 70, 1e-12);
  EXPECT_NEAR(female.forearm.mass_kg, 0.0138 * 70, 1e-12);
  EXPECT_NEAR(neutral.forearm.mass_kg, 0.016 * 70, 1e-12);
  EXPECT_NEAR(male.upper_arm.com_from_proximal_m, 0.5772 * male.upper_arm.length_m, 1e-12);
  EXPECT_EQ(male.hand.mass_kg, neutral.hand.mass_kg);  // the hand keeps Winter's row
}

}  // namespace
}  // namespace peha
