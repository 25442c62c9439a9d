#include "peha/experiments/robustness/robustness.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/models/units.hpp"
#include "../support/shipped_scenarios.hpp"

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <unistd.h>
#include <string>

namespace peha::experiments {
namespace {

using ::testing::HasSubstr;

// The shipped matrix reads: every variant of issue 10 is there, as plant-only knobs.
TEST(Robustness, ShippedMatrixHasEveryVariantOfTheIssue) {
  const RobustnessConfig c = read_robustness(config::Document::load_file(PEHA_SOURCE_DIR "/configs/robustness.yaml"));
  EXPECT_EQ(c.modes.size(), 6u);
  EXPECT_EQ(c.modes[2], RobustnessMode::kE1SensorChecked);
  EXPECT_EQ(c.modes[4], RobustnessMode::kE3Identified);
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
  const E1Scenario s = peha::test_support::shipped_e1();
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
  const E1Scenario s = peha::test_support::shipped_e1();
  PlantVariant link;
  link.link_mass_scale = 1.2;
  EXPECT_EQ(e1_variant_plant(s, s.cases[0], link).payload_kg, 2.5);  // what the controller is told, unchanged
  EXPECT_NEAR(e1_variant_plant(s, s.cases[0], link).unknown_payload_kg, 0.2 * 0.45 * 0.2 / 0.4, 1e-9);
  PlantVariant cable;
  cable.cable_friction_scale = 0.5;
  const sim::OneDofRigParams p = e1_variant_plant(s, s.cases[0], cable);
  EXPECT_DOUBLE_EQ(p.joint.agonist.cable.static_friction, 0.5 * s.plant.joint.agonist.cable.static_friction);
  EXPECT_DOUBLE_EQ(p.joint.antagonist.cable.kinetic_friction, 0.5 * s.plant.joint.antagonist.cable.kinetic_friction);
  const ArmScenario arm = peha::test_support::shipped_right_arm();
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
  const RobustnessResult r = run_robustness(c);
  ASSERT_EQ(r.rows.size(), 1u);
  EXPECT_FALSE(r.rows[0].verdict);
  // It sinks (drift) with its wires taut (the trim's slack rate): the goal's figures - static error
  // at the released postures and tension - are met, the verdict's drift is not.
  EXPECT_GT(r.rows[0].drift_deg, 10.0);
  EXPECT_GE(r.rows[0].tension_fraction, 0.5);
  EXPECT_TRUE(r.rows[0].physics_forbids);
  EXPECT_THAT(r.rows[0].physics_reason, HasSubstr("no cable friction"));
}

// E4 in the shipped matrix (issue 31, item 4): both paces on every variant, the valves from 0.5 to 3 x,
// and the persons of the issue - strokes up to 400 deg/s, 6-8 Hz tremors of up to 3 deg, an arm 15 %
// longer and heavier or shorter and lighter - each inside the elbow's range, its goal share 90 %.
TEST(RobustnessE4, ShippedMatrixHasThePacesVariantsAndPersonsOfTheIssue) {
  const RobustnessConfig c = read_robustness(config::Document::load_file(PEHA_SOURCE_DIR "/configs/robustness.yaml"));
  ASSERT_EQ(c.modes.back(), RobustnessMode::kE4);
  EXPECT_EQ(c.e4_min_share, 0.9);
  ASSERT_EQ(c.e4.paces.size(), 2u);
  EXPECT_EQ(c.e4.paces[0].scenario_movement, "slow");
  EXPECT_EQ(c.e4.paces[1].scenario_movement, "brisk");
  EXPECT_TRUE(c.e4.variants.empty());  // every variant
  std::vector<double> valves;
  for (const PlantVariant& v : c.variants) valves.push_back(v.valve_time_scale);
  for (double x : {0.5, 1.5, 2.0, 3.0}) EXPECT_NE(std::find(valves.begin(), valves.end(), x), valves.end()) << x;
  const RobustnessScenarios s = read_robustness_scenarios(c);  // every person inside the elbow's range
  double fastest_degps = 0, tremor_lo_Hz = 100, tremor_hi_Hz = 0, longest = 1, shortest = 1;
  for (const GoniometerPerson& p : c.e4.persons) {
    const ArmScenario::Goniometer::Movement m = person_movement(s.arm, p);
    // A minimum-jerk stroke peaks at 1.875 x its mean speed.
    fastest_degps = std::max(fastest_degps, 1.875 * models::rad_to_deg(std::abs(m.to_rad - m.from_rad)) / m.move_s);
    if (m.tremor_frequency_Hz > 0) {
      tremor_lo_Hz = std::min(tremor_lo_Hz, m.tremor_frequency_Hz);
      tremor_hi_Hz = std::max(tremor_hi_Hz, m.tremor_frequency_Hz);
      EXPECT_LE(models::rad_to_deg(m.tremor_amplitude_rad), 3.0 + 1e-9) << p.name;
    }
    longest = std::max(longest, p.segment_length_scale);
    shortest = std::min(shortest, p.segment_mass_scale);
  }
  EXPECT_NEAR(fastest_degps, 400.0, 2.0);
  EXPECT_EQ(tremor_lo_Hz, 6.0);
  EXPECT_EQ(tremor_hi_Hz, 8.0);
  EXPECT_EQ(longest, 1.15);
  EXPECT_EQ(shortest, 0.85);
}

// The E4 section's reader is strict: an unknown key, a tremor without its frequency, a movement the arm
// scenario does not have and a person beyond the elbow's 135 deg stop are refused, each by name.
TEST(RobustnessE4, ReaderRefusesWrongPersons) {
  auto matrix = [](const std::string& person) {
    return config::Document::load_string("experiment: robustness\ndescription: E4 persons\nseed: 1\narm_scenario: " PEHA_SOURCE_DIR
                                         "/configs/right_arm.yaml\nmodes: {e4_goniometer: true}\nthreads: 1\n"
                                         "variants: [{name: nominal}]\ne4:\n  paces: [brisk]\n  persons: [" + person + "]\n",
                                         "matrix.yaml");
  };
  EXPECT_NO_THROW(read_robustness(matrix("{name: p, movement: slow, tremor_amplitude_deg: 3, tremor_frequency_Hz: 7}")));
  EXPECT_THROW(read_robustness(matrix("{name: p, movement: slow, tremor_deg: 3}")), config::Error);
  EXPECT_THROW(read_robustness(matrix("{name: p, movement: slow, tremor_amplitude_deg: 3}")), config::Error);
  const RobustnessConfig unknown = read_robustness(matrix("{name: p, movement: sprint}"));
  EXPECT_THAT([&] { read_robustness_scenarios(unknown); }, ::testing::ThrowsMessage<config::Error>(HasSubstr("sprint")));
  const RobustnessConfig far = read_robustness(matrix("{name: far, from_deg: 40, to_deg: 140, move_s: 1, pause_s: 0.3, repetitions: 1}"));
  EXPECT_THAT([&] { read_robustness_scenarios(far); }, ::testing::ThrowsMessage<config::Error>(HasSubstr("far: reaches 140.0 deg")));
}

// The tremor is the person's: the truth is the movement plus A sin(2 pi f t) exactly (zero at the start,
// where the arm is put), and the goniometer reads it with its noise.
TEST(RobustnessE4, ATremorIsAddedToThePersonsMovement) {
  const ArmScenario arm = peha::test_support::shipped_right_arm();
  ArmScenario::Goniometer::Movement m = arm.goniometer.movements.back();
  const GoniometerTrace plain = synthesize_goniometer(arm.goniometer, m, 1);
  m.tremor_amplitude_rad = models::deg_to_rad(3.0);
  m.tremor_frequency_Hz = 7.0;
  const GoniometerTrace tremor = synthesize_goniometer(arm.goniometer, m, 1);
  ASSERT_EQ(plain.truth_rad.size(), tremor.truth_rad.size());
  double peak = 0, reading_rms = 0;
  for (std::size_t k = 0; k < plain.truth_rad.size(); ++k) {
    const double t = static_cast<double>(k) / arm.goniometer.sample_rate_Hz;
    const double d = tremor.truth_rad[k] - plain.truth_rad[k];
    ASSERT_NEAR(d, m.tremor_amplitude_rad * std::sin(2.0 * std::numbers::pi * 7.0 * t), 1e-12) << k;
    peak = std::max(peak, std::abs(d));
    reading_rms += std::pow(tremor.measured_rad[k] - tremor.truth_rad[k], 2);
  }
  EXPECT_NEAR(models::rad_to_deg(peak), 3.0, 0.05);
  EXPECT_NEAR(models::rad_to_deg(std::sqrt(reading_rms / static_cast<double>(plain.truth_rad.size()))), 0.2, 0.03);  // noise_deg
  EXPECT_EQ(tremor.truth_rad.front(), plain.truth_rad.front());
}

// Another anthropometry changes the user's segments in the plant only: the forearm 15 % longer and
// heavier has its centre of mass x 1.15, its mass x 1.15 and its inertia x 1.15^3; the exoskeleton's
// links and the controller's model are untouched.
TEST(RobustnessE4, AnotherArmScalesOnlyTheUsersSegments) {
  const ArmScenario arm = peha::test_support::shipped_right_arm();
  RobustnessConfig c;
  c.arm_config = PEHA_SOURCE_DIR "/configs/right_arm.yaml";
  const sim::ArmPlantParams before = arm.plant;
  sim::ArmPlantParams after = arm.plant;
  scale_user_arm(after, 1.15, 1.15);
  std::size_t users = 0;
  for (std::size_t i = 0; i < before.model.bodies.size(); ++i) {
    const models::ArmBody &b = before.model.bodies[i], &a = after.model.bodies[i];
    if (models::without_side(b.name).starts_with("user_")) {
      ++users;
      EXPECT_DOUBLE_EQ(a.mass_kg, 1.15 * b.mass_kg) << b.name;
      EXPECT_TRUE(a.com_m.isApprox(1.15 * b.com_m)) << b.name;
      EXPECT_TRUE(a.inertia_kgm2.isApprox(std::pow(1.15, 3) * b.inertia_kgm2)) << b.name;
    } else {
      EXPECT_EQ(a.mass_kg, b.mass_kg) << b.name;
      EXPECT_TRUE(a.com_m.isApprox(b.com_m)) << b.name;
    }
  }
  EXPECT_EQ(users, 3u);  // upper arm, forearm, hand
}

// The short E4 matrix `make test` runs: the brisk pace on the nominal plant with the shipped
// controller passes every figure (goal share 1/1); the same case with a deliberately wrong controller -
// no damping in the elbow's impedance and in the shoulder's hold - fails its verdict, and the share
// drops below the 90 % goal. Neither is marked physics forbids (the person moves at 225 deg/s, no tremor).
TEST(RobustnessE4, ShortMatrixMeetsTheGoalAndAWrongControllerMissesIt) {
  RobustnessConfig c;
  c.arm_config = PEHA_SOURCE_DIR "/configs/right_arm.yaml";
  c.modes = {RobustnessMode::kE4};
  c.seeds = {1};
  c.threads = 2;
  PlantVariant nominal;
  nominal.name = "nominal";
  c.variants = {nominal};
  GoniometerPerson brisk;
  brisk.name = brisk.scenario_movement = "brisk";
  c.e4.paces = {brisk};
  RobustnessScenarios shipped = read_robustness_scenarios(c);
  RobustnessScenarios wrong = shipped;
  wrong.arm.goniometer.feedback_damping_Nms_per_rad = 0.0;
  wrong.arm.goniometer.hold_damping_Nms_per_rad = 0.0;
  const RobustnessResult good = run_robustness(c, shipped);
  const RobustnessResult bad = run_robustness(c, wrong);
  ASSERT_EQ(good.rows.size(), 1u);
  ASSERT_EQ(bad.rows.size(), 1u);
  const RobustnessRow& g = good.rows[0];
  EXPECT_EQ(g.mode, "e4_goniometer");
  EXPECT_EQ(g.payload, "brisk");
  EXPECT_TRUE(g.verdict) << g.failures;
  EXPECT_FALSE(g.physics_forbids);
  EXPECT_NEAR(g.e4.person_speed_degps, 225.0, 3.0);  // 1.875 x 60 deg / 0.5 s
  EXPECT_LT(g.e4.rms_error_deg, 5.0);
  EXPECT_LT(g.e4.command_hf_rms_Nm, 0.1);
  EXPECT_LT(g.e4.passive_speed_degps, 400.0);
  EXPECT_LT(g.e4.held_excursion_deg, 2.0);
  ASSERT_EQ(good.shares.size(), 1u);
  EXPECT_TRUE(good.shares[0].ok());
  const RobustnessRow& b = bad.rows[0];
  EXPECT_FALSE(b.verdict);
  EXPECT_FALSE(b.physics_forbids);
  EXPECT_FALSE(bad.shares[0].ok());
  EXPECT_EQ(bad.shares[0].met, 0u);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_robustness_e4_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_robustness(dir, c, bad);
  std::ifstream md(dir / "robustness.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("| nominal | brisk | 225 |"));
  EXPECT_THAT(text.str(), HasSubstr("control defect (physics allows it)"));
  std::filesystem::remove_all(dir);
}

// Physics forbids an E4 case, before it runs and with the number, when the person moves faster than
// the supervisor lets a joint move (here 30 -> 105 deg in 0.2 s: 703 deg/s against 500) - and only then
// or for a tremor past the tracking limit; the shipped persons are all allowed.
TEST(RobustnessE4, APersonFasterThanTheSupervisorAllowsIsMarkedPhysicsForbids) {
  RobustnessConfig c;
  c.arm_config = PEHA_SOURCE_DIR "/configs/right_arm.yaml";
  c.modes = {RobustnessMode::kE4};
  c.seeds = {1};
  c.threads = 1;
  PlantVariant nominal;
  nominal.name = "nominal";
  c.variants = {nominal};
  GoniometerPerson sprint;
  sprint.name = "sprint";
  sprint.movement = {"sprint", models::deg_to_rad(30.0), models::deg_to_rad(105.0), 0.2, 0.3, 1};
  c.e4.persons = {sprint};
  const RobustnessResult r = run_robustness(c);
  ASSERT_EQ(r.rows.size(), 1u);
  EXPECT_NEAR(r.rows[0].e4.person_speed_degps, 1.875 * 75.0 / 0.2, 10.0);
  EXPECT_TRUE(r.rows[0].physics_forbids);
  EXPECT_THAT(r.rows[0].physics_reason, HasSubstr("faster than the supervisor lets any joint move (500 deg/s)"));
  EXPECT_FALSE(r.rows[0].verdict);  // it trips
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

namespace peha::experiments {
namespace {

PlantVariant one_sensor_variant(const char* name, double agonist_gain, double pulley) {
  PlantVariant v;
  v.name = name;
  v.agonist_loadcell_gain_scale = agonist_gain;
  v.pulley_radius_scale = pulley;
  return v;
}

// Issue 31 item 5 in the matrix: the single-sensor errors E1's default controller misses its 5 % on
// (an agonist cell 5 % low, the pulley 5 % larger: 9.3 and 7.9 % at 2.5 kg) meet it once the sensor
// check has run on the variant (`e1_sensor_checked`: its corrections in the controller, then E1 as
// e1_default). A cell whose zero lies below its channel's range is refused by the check and its
// variant fails with the reason (the corrections' own failure, a wrong known mass, is
// SensorCheck.AWrongKnownMassGivesCorrectionsThatFailE1sStaticError).
TEST(RobustnessSensorCheck, AfterTheCheckEachSingleSensorErrorMeetsTheGoalAndAZeroBelowTheChannelIsRefused) {
  RobustnessConfig c;
  c.e1_config = PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml";
  c.modes = {RobustnessMode::kE1Default, RobustnessMode::kE1SensorChecked};
  c.seeds = {1};
  c.threads = 2;
  c.e1_cases = {"payload_2.5kg"};
  c.variants = {one_sensor_variant("agonist_gain_-5%", 0.95, 1.0), one_sensor_variant("pulley_radius_+5%", 1.0, 1.05)};
  const RobustnessResult good = run_robustness(c);
  ASSERT_EQ(good.rows.size(), 4u);
  for (const RobustnessRow& r : good.rows) {
    std::printf("%s %s: static torque error %.1f %%, goal %s\n", r.mode.c_str(), r.variant.c_str(), r.static_error_pct, r.goal ? "met" : "missed");
    if (r.mode == "e1_default") {
      EXPECT_GT(r.static_error_pct, 5.0) << r.variant;
      EXPECT_FALSE(r.goal) << r.variant;
    } else {
      EXPECT_EQ(r.mode, "e1_sensor_checked");
      EXPECT_LE(r.static_error_pct, 5.0) << r.variant;
      EXPECT_TRUE(r.goal) << r.variant << ": " << r.failures;
    }
  }
  ASSERT_EQ(good.shares.size(), 2u);
  EXPECT_FALSE(good.shares[0].ok());
  EXPECT_TRUE(good.shares[1].ok());

  // A zero below the channel's bottom reads code 0 vented: the check refuses it, and that refusal is
  // the designed outcome (the amplifier's offset is set on the hardware), reported apart from the
  // share. A run that does not refuse (pure feed-forward reads no cell) is judged by its figures.
  PlantVariant below = one_sensor_variant("agonist_zero_-20N", 1.0, 1.0);
  below.agonist_loadcell_bias_N = -20.0;
  c.modes = {RobustnessMode::kE1SensorChecked, RobustnessMode::kE1CalibratedFF};
  c.variants = {below};
  const RobustnessResult refused = run_robustness(c);
  ASSERT_EQ(refused.rows.size(), 2u);
  for (const RobustnessRow& r : refused.rows) {
    if (r.mode == "e1_sensor_checked") {
      EXPECT_FALSE(r.goal);
      EXPECT_THAT(r.failures, HasSubstr("sensor check refused: "));
      EXPECT_TRUE(r.physics_forbids);
      EXPECT_THAT(r.physics_reason, HasSubstr("below its channel's bottom"));
    } else {
      EXPECT_FALSE(r.physics_forbids) << r.physics_reason;
    }
  }
  for (const RobustnessResult::Share& share : refused.shares) {
    if (share.mode == "e1_sensor_checked") {
      EXPECT_FALSE(share.ok());  // nothing left to judge is not a met share
    }
  }
}

}  // namespace
}  // namespace peha::experiments
