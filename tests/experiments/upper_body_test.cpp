// E3 on the upper body (configs/upper_body.yaml): both arms, eight driven joints from the body's joint
// list, symmetric and asymmetric postures.
#include "peha/experiments/e3_postures/postures.hpp"

#include "../support/verdict_checks.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace peha::experiments {
namespace {

ArmScenario upper_body() { return read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml")); }

const PostureJointResult& figure(const PostureResult& p, const std::string& joint) {
  for (const PostureJointResult& j : p.joints) {
    if (j.joint == joint) return j;
  }
  ADD_FAILURE() << p.name << " has no figure for " << joint;
  return p.joints.front();
}

TEST(UpperBodyScenario, DrivesBothArmsFromTheJointList) {
  const ArmScenario s = upper_body();
  const std::vector<std::string> expected = {"R_SAA", "R_SFE", "R_EFE", "R_WFE", "L_SAA", "L_SFE", "L_EFE", "L_WFE"};
  EXPECT_EQ(s.plant.actuated, expected);
  ASSERT_EQ(s.controller.joints.size(), 8u);
  EXPECT_EQ(s.controller.joints[4].model_joint, 6);  // L_SAA: the left arm's first model joint
  EXPECT_EQ(s.controller.joints[3].mode, control::ArmJointMode::kHoldPressure);
  EXPECT_TRUE(s.controller.joints[5].actuator.has_motor);
  EXPECT_FALSE(s.controller.joints[7].actuator.has_motor);
  EXPECT_EQ(gravity_joints(s).size(), 6u);
  EXPECT_EQ(arm_log_prefix(s, 5), "l_sfe");
  // A posture names joints for both arms or one side.
  const ArmPosture& raise = s.postures.back();
  EXPECT_NEAR(raise.target_rad[0], 60 * 3.14159265358979 / 180, 1e-12);  // R_SAA
  EXPECT_NEAR(raise.target_rad[4], 0.0, 1e-12);                           // L_SAA
  EXPECT_TRUE(std::isnan(raise.target_rad[3]));                           // the wrists are left free
}

// Both arms stay where they were left (drift far below the threshold), mirror-image postures give the
// same figures on both sides, and the static torque error is what the prior does not know about the
// plant's heavier arms - so the run fails its static-error figures until the upper body is identified.
TEST(UpperBodyScenario, BothArmsHoldMirrorPosturesAndTheirStaticErrorIsThePriors) {
  const ArmScenario s = upper_body();
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.postures.size(), s.postures.size());
  EXPECT_EQ(r.faults, 0u) << r.fault_reason;
  for (const PostureResult& p : r.postures) {
    ASSERT_EQ(p.joints.size(), 6u);
    for (const PostureJointResult& j : p.joints) {
      EXPECT_LT(std::abs(j.drift_deg), s.verdict.max_drift_deg) << p.name << " " << j.joint;
      if (std::abs(j.gravity_torque_Nm) < s.verdict.min_gravity_torque_Nm) continue;
      EXPECT_NEAR(j.static_torque_error_pct, j.model_gravity_error_pct, 2.0) << p.name << " " << j.joint;
    }
  }
  for (const char* name : {"elbows_90", "abducted_45"}) {
    const PostureResult& p = *std::find_if(r.postures.begin(), r.postures.end(), [&](const PostureResult& q) { return q.name == name; });
    for (const char* joint : {"SAA", "SFE", "EFE"}) {
      const PostureJointResult& right = figure(p, std::string("R_") + joint);
      const PostureJointResult& left = figure(p, std::string("L_") + joint);
      EXPECT_NEAR(right.released_deg, left.released_deg, 0.05) << name << " " << joint;
      EXPECT_NEAR(right.gravity_torque_Nm, left.gravity_torque_Nm, 0.02 * std::abs(right.gravity_torque_Nm) + 0.05) << name << " " << joint;
    }
  }
  // The asymmetric posture: the right arm hangs while the left is raised and flexed.
  const PostureResult& raise = r.postures.back();
  EXPECT_GT(std::abs(figure(raise, "L_SFE").gravity_torque_Nm), 10.0);
  EXPECT_TRUE(testing::fails_on(r.verdict, "elbows_90 L_EFE |static torque error|")) << r.verdict.failures();
  EXPECT_TRUE(testing::fails_on(r.verdict, "elbows_90 R_EFE |static torque error|")) << r.verdict.failures();
}

}  // namespace
}  // namespace peha::experiments
