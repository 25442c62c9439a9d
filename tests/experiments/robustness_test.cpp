#include "peha/experiments/robustness/robustness.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <unistd.h>
#include <string>

namespace peha::experiments {
namespace {

using ::testing::HasSubstr;

// The shipped matrix reads: every variant of issue 10 is there, as plant-only knobs.
TEST(Robustness, ShippedMatrixHasEveryVariantOfTheIssue) {
  const RobustnessConfig c = read_robustness(config::Document::load_file(PEHA_SOURCE_DIR "/configs/robustness.yaml"));
  EXPECT_EQ(c.modes.size(), 4u);
  EXPECT_EQ(c.modes.back(), RobustnessMode::kE3Identified);
  std::vector<std::string> names;
  for (const PlantVariant& v : c.variants) names.push_back(v.name);
  for (const char* name : {"nominal", "cable_friction_x0", "cable_friction_x0.25", "cable_friction_x0.5", "cable_friction_x1.5",
                           "cable_friction_x2", "valve_slow_x2", "muscle_strength_+15%", "muscle_strength_-15%", "wire_stiffness_x0.5",
                           "loadcell_bias_+40N", "loadcell_bias_-40N", "sensor_noise_x3", "link_mass_+20%", "link_mass_-20%",
                           "unknown_payload_+20%", "unknown_payload_-20%", "hand_payload_+1kg"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  }
  EXPECT_EQ(c.goal_calibrated.min_share, 0.9);
}

// One sensor's own calibration error (issue 31): a variant moves one cell's zero or gain, or the
// pulley's radius, and nothing else - equal errors on both cells cancel in the torque balance, these
// do not. The shipped matrix has each at +-20 N, +-5 % and +-5 %.
TEST(Robustness, ASingleSensorErrorActsOnItsOwnSensor) {
  const RobustnessConfig c = read_robustness(config::Document::load_file(PEHA_SOURCE_DIR "/configs/robustness.yaml"));
  std::vector<std::string> names;
  for (const PlantVariant& v : c.variants) names.push_back(v.name);
  for (const char* name : {"agonist_zero_+20N", "agonist_zero_-20N", "antagonist_zero_+20N", "antagonist_zero_-20N", "agonist_gain_+5%",
                           "agonist_gain_-5%", "antagonist_gain_+5%", "antagonist_gain_-5%", "pulley_radius_+5%", "pulley_radius_-5%"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  }
  const E1Scenario s = read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  const sim::PehaJointPlantParams& nominal = s.plant.joint;
  PlantVariant zero;
  zero.antagonist_loadcell_bias_N = -20.0;
  const sim::OneDofRigParams z = e1_variant_plant(s, s.cases[0], zero);
  EXPECT_DOUBLE_EQ(z.joint.antagonist.loadcell_offset_N, nominal.antagonist.loadcell_offset_N - 20.0);
  EXPECT_DOUBLE_EQ(z.joint.agonist.loadcell_offset_N, nominal.agonist.loadcell_offset_N);
  PlantVariant gain;
  gain.agonist_loadcell_gain_scale = 0.95;
  const sim::OneDofRigParams g = e1_variant_plant(s, s.cases[0], gain);
  EXPECT_DOUBLE_EQ(g.joint.agonist.loadcell_gain, 0.95 * nominal.agonist.loadcell_gain);
  EXPECT_DOUBLE_EQ(g.joint.antagonist.loadcell_gain, nominal.antagonist.loadcell_gain);
  PlantVariant pulley;
  pulley.pulley_radius_scale = 1.05;
  EXPECT_DOUBLE_EQ(e1_variant_plant(s, s.cases[0], pulley).joint.pulley_radius_m, 1.05 * nominal.pulley_radius_m);
  EXPECT_DOUBLE_EQ(e1_variant_plant(s, s.cases[0], pulley).joint.agonist.loadcell_gain, nominal.agonist.loadcell_gain);
}

// A variant changes only the plant: the E1 plant under "link mass +20 %" carries the payload with
// the same extra gravity torque (0.45 kg arm at 0.2 m: +0.018 kg m -> +0.045 kg at 0.4 m), the
// cable variant scales both cables' friction, and the E3 variant puts the unknown mass in the hand.
TEST(Robustness, VariantsChangeOnlyThePlant) {
  const E1Scenario s = read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  PlantVariant link;
  link.link_mass_scale = 1.2;
  EXPECT_EQ(e1_variant_plant(s, s.cases[0], link).payload_kg, 2.5);  // what the controller is told, unchanged
  EXPECT_NEAR(e1_variant_plant(s, s.cases[0], link).unknown_payload_kg, 0.2 * 0.45 * 0.2 / 0.4, 1e-9);
  PlantVariant cable;
  cable.cable_friction_scale = 0.5;
  const sim::OneDofRigParams p = e1_variant_plant(s, s.cases[0], cable);
  EXPECT_DOUBLE_EQ(p.joint.agonist.cable.static_friction, 0.5 * s.plant.joint.agonist.cable.static_friction);
  EXPECT_DOUBLE_EQ(p.joint.antagonist.cable.kinetic_friction, 0.5 * s.plant.joint.antagonist.cable.kinetic_friction);
  const ArmScenario arm = read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml"));
  PlantVariant hand;
  hand.extra_payload_kg = 1.0;
  EXPECT_EQ(arm_variant_plant(arm, hand).unknown_hand_payload_kg, 1.0);
}

// The small subset `make test` runs: E1 (default controller) and E3 (the shipped, identified arm model)
// on the nominal plant and with an unknown +20 % payload, on two threads. The nominal E1 and E3 meet
// their goals and pass; the unknown payload is flagged as a case physics forbids and E1's verdict fails
// on the static torque error (the controller cannot know the mass) - it does not pass silently.
// Files: robustness.md/.csv.
TEST(Robustness, SmallMatrixJudgesEveryCaseHonestly) {
  RobustnessConfig c;
  c.e1_config = PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml";
  c.arm_config = PEHA_SOURCE_DIR "/configs/right_arm.yaml";
  c.modes = {RobustnessMode::kE1Default, RobustnessMode::kE3};
  c.seeds = {1};
  c.e1_cases = {"payload_5.0kg"};
  c.threads = 2;
  PlantVariant nominal;
  nominal.name = "nominal";
  PlantVariant heavy;
  heavy.name = "unknown_payload_+20%";
  heavy.payload_scale = 1.2;
  c.variants = {nominal, heavy};
  std::size_t calls = 0;
  const RobustnessResult r = run_robustness(c, [&](std::size_t, std::size_t total, const std::string&) {
    ++calls;
    EXPECT_EQ(total, 4u);
  });
  ASSERT_EQ(r.rows.size(), 4u);
  EXPECT_EQ(calls, 4u);
  const RobustnessRow& e1_nominal = r.rows[0];
  const RobustnessRow& e1_heavy = r.rows[1];
  EXPECT_EQ(e1_nominal.mode, "e1_default");
  EXPECT_TRUE(e1_nominal.verdict) << e1_nominal.failures;
  EXPECT_TRUE(e1_nominal.goal);
  EXPECT_LT(e1_nominal.static_error_pct, 5.0);
  EXPECT_GT(e1_nominal.tension_fraction, 0.5);
  EXPECT_TRUE(e1_heavy.physics_forbids);
  EXPECT_FALSE(e1_heavy.verdict);
  EXPECT_GT(e1_heavy.static_error_pct, 10.0);  // 20 % of the payload's ~95 % share of the gravity torque
  EXPECT_THAT(e1_heavy.failures, HasSubstr("static torque error"));
  EXPECT_EQ(r.rows[2].mode, "e3_postures");
  // The shipped arm's controller uses the gravity identified on the rig (configs/arm/right_arm_gravity.yaml):
  // its static torque error (truth) is within the goal (measured 1.7 %; the body file's prior gave up
  // to 10.4 %, E3.StaticTorqueErrorIsTheGravityTheControllerDoesNotKnow), and stays the model's error.
  EXPECT_LT(r.rows[2].static_error_pct, 5.0);
  EXPECT_NEAR(r.rows[2].static_error_pct, r.rows[2].model_gravity_error_pct, 1.5);
  EXPECT_FALSE(r.rows[2].physics_forbids);
  EXPECT_TRUE(r.rows[2].goal);
  EXPECT_TRUE(r.rows[2].verdict) << r.rows[2].failures;
  EXPECT_TRUE(r.rows[3].physics_forbids);  // the unknown payload in E3
  EXPECT_LT(r.rows[2].drift_deg, 0.5);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_robustness_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_robustness(dir, c, r);
  std::ifstream md(dir / "robustness.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("| unknown_payload_+20% | payload_5.0kg | e1_default |"));
  EXPECT_THAT(text.str(), HasSubstr("plant gravity the controller is not told"));
  EXPECT_THAT(text.str(), HasSubstr("% off the plant's (identify it on the rig)"));
  std::filesystem::remove_all(dir);
}

// With no cable friction nothing but the torque balance holds the arm: E3's feed-forward follows the
// arm wherever it goes, so the shipped model's 1-2 % error sinks it (measured: 45.7 deg, static error
// 1.9 %, the wires at 0.93 x the pretension; before the trim's slack rate 115 deg, 6.2 % and a slack
// wire) - the verdict fails, and the row is marked as a case physics forbids to a controller without
// position feedback, with that reason. (Its goal - static error and tension - is now met, so the
// matrix counts it as met: the goal does not judge drift.)
TEST(Robustness, AFrictionlessArmSinksAndIsMarkedPhysicsForbidsWithItsReason) {
  RobustnessConfig c;
  c.e1_config = PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml";
  c.arm_config = PEHA_SOURCE_DIR "/configs/right_arm.yaml";
  c.modes = {RobustnessMode::kE3};
  c.seeds = {1};
  c.threads = 1;
  PlantVariant frictionless;
  frictionless.name = "cable_friction_x0";
  frictionless.cable_friction_scale = 0.0;
  c.variants = {frictionless};
  const RobustnessResult r = run_robustness(c, {});
  ASSERT_EQ(r.rows.size(), 1u);
  EXPECT_FALSE(r.rows[0].verdict);
  // It sinks (drift) with its wires taut (the trim's slack rate): the goal's figures - static error
  // at the released postures and tension - are met, the verdict's drift is not.
  EXPECT_GT(r.rows[0].drift_deg, 10.0);
  EXPECT_GE(r.rows[0].tension_fraction, 0.5);
  EXPECT_TRUE(r.rows[0].physics_forbids);
  EXPECT_THAT(r.rows[0].physics_reason, HasSubstr("no cable friction"));
}

}  // namespace
}  // namespace peha::experiments

namespace peha::experiments {
namespace {

// The required share is judged over the cases physics allows: e1_calibrated_ff's 30 of 34 with the
// four unknown-payload cases forbidden meets 90 %; 26 of the same 34 does not (26/30 = 87 %); a
// forbidden case the goal still met counts as met, not as forbidden; no judged case is never OK.
TEST(RobustnessShare, IsJudgedOverTheCasesPhysicsAllows) {
  RobustnessResult::Share s{"e1_calibrated_ff", 30, 34, 4, 0.9};
  EXPECT_EQ(s.judged(), 30u);
  EXPECT_TRUE(s.ok());
  s.met = 26;
  EXPECT_FALSE(s.ok());
  RobustnessResult::Share all_forbidden{"e3_postures", 0, 4, 4, 1.0};
  EXPECT_FALSE(all_forbidden.ok());
}

}  // namespace
}  // namespace peha::experiments
