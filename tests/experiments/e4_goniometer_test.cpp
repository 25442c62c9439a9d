// E4: a person's elbow, measured by a goniometer, drives the exoskeleton's elbow through the
// Butterworth filter, derivatives and the forearm + hand inverse dynamics.
#include "peha/experiments/e4_goniometer/goniometer.hpp"

#include "peha/calibration/dataset.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/plant_faults.hpp"

#include <fmt/format.h>

#include <yaml-cpp/yaml.h>

#include <gmock/gmock.h>
#include "../support/verdict_checks.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <array>
#include <functional>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>
#include <unistd.h>
#include <string>

namespace peha::experiments {
namespace {


const ArmScenario::Goniometer::Movement& movement(const ArmScenario& s, const std::string& name) {
  for (const auto& m : s.goniometer.movements) {
    if (m.name == name) return m;
  }
  throw std::runtime_error("no movement " + name);
}

// The synthetic person: minimum-jerk flexion 40 -> 100 deg and back, sampled at 200 Hz; the
// goniometer adds its 0.2 deg noise and 0.1 deg quantisation to the truth.
TEST(E4, SyntheticGoniometerIsThePersonsMovementPlusNoise) {
  const ArmScenario s = test_support::shipped_right_arm();
  const auto& m = movement(s, "slow");
  const GoniometerTrace t = synthesize_goniometer(s.goniometer, m, 7);
  const double expected_s = m.repetitions * 2.0 * (m.move_s + m.pause_s) + m.pause_s;
  EXPECT_NEAR(t.duration_s(), expected_s, 2.0 / t.sample_rate_Hz);
  double lo = 1e9, hi = -1e9, sum = 0.0;
  for (std::size_t k = 0; k < t.truth_rad.size(); ++k) {
    lo = std::min(lo, t.truth_rad[k]);
    hi = std::max(hi, t.truth_rad[k]);
    const double e = t.measured_rad[k] - t.truth_rad[k];
    sum += e * e;
  }
  EXPECT_NEAR(lo, m.from_rad, 1e-12);
  EXPECT_NEAR(hi, m.to_rad, 1e-12);
  // Noise 0.2 deg plus uniform quantisation 0.1 / sqrt(12) deg.
  const double expected_rms = std::hypot(s.goniometer.noise_rad, s.goniometer.resolution_rad / std::sqrt(12.0));
  EXPECT_NEAR(std::sqrt(sum / t.truth_rad.size()), expected_rms, 0.1 * expected_rms);
  EXPECT_EQ(synthesize_goniometer(s.goniometer, m, 7).measured_rad, t.measured_rad);  // same seed, same noise
}

// The paper's pure replay of the inverse-dynamics torque cannot overcome the Bowden stiction of the
// elbow for a slow movement (the torque differences are ~1-2 Nm against a ~2 Nm band): the exoskeleton
// lags far behind. Adding the impedance toward the goniometer angle makes it follow within a few
// degrees, the lag being the filter's 35 ms plus the valves'. Safety figures hold throughout.
TEST(E4, ExoskeletonElbowFollowsThePersonWithFeedbackButNotOnPureReplay) {
  const ArmScenario s = test_support::shipped_right_arm();
  for (const char* name : {"slow", "brisk"}) {
    const GoniometerTrace t = synthesize_goniometer(s.goniometer, movement(s, name), s.seed);
    const GoniometerResult open = run_goniometer(s, {t}, GoniometerVariant::kOpenLoop, nullptr);
    const GoniometerResult fb = run_goniometer(s, {t}, GoniometerVariant::kFeedback, nullptr);
    ASSERT_EQ(fb.joints.size(), 1u);  // the right arm's goniometer drives R_EFE
    const GoniometerJointResult& f = fb.joints[0];
    const GoniometerJointResult& o = open.joints[0];
    EXPECT_EQ(f.joint, "R_EFE");
    EXPECT_NEAR(f.range_deg, 60.0, 0.5) << name;
    EXPECT_LT(f.rms_error_deg, 8.0) << name;
    EXPECT_LT(f.rms_error_aligned_deg, 3.0) << name;
    EXPECT_GT(f.delay_s, open.filter_delay_s) << name;  // at least the Butterworth's group delay
    EXPECT_LT(f.delay_s, 0.15) << name;
    EXPECT_GT(o.rms_error_deg, 3.0 * f.rms_error_deg) << name;
    EXPECT_NEAR(open.filter_delay_s, 0.0345, 0.0005);  // sqrt(2) / Omega_c for N = 2, 6.5 Hz at 200 Hz
    // The tracking figures are in the verdict: pure replay fails both, by far.
    EXPECT_TRUE(testing::fails_on(open.verdict, "R_EFE tracking RMS error")) << name;
    EXPECT_TRUE(testing::fails_on(open.verdict, "R_EFE tracking max error")) << name;
    EXPECT_FALSE(open.within_limits) << name;
    if (std::string(name) == "slow") {
      EXPECT_FALSE(testing::fails_on(fb.verdict, "R_EFE tracking")) << fb.verdict.failures();
    }
    for (const GoniometerResult* r : {&open, &fb}) {
      // Beyond tracking, only tension floors (the wrist's, see E3) and, at the brisk pace, the figures
      // E4's smoothing does not reach yet may fail (E4.EveryHeldAndPassiveJointAndTheCommandAreJudged).
      for (const std::string& f : testing::failed_figures(r->verdict)) {
        EXPECT_TRUE(f.ends_with("lowest wire tension") || f.starts_with("R_EFE tracking") || f.starts_with("R_EFE torque command") ||
                    f == "R_WFE passive peak speed")
            << name << ": " << f;
      }
      // The supervisor's plausibility stage is on and raises nothing on the person's movement (its
      // figure is judged; a false alarm would fail it above).
      EXPECT_TRUE(testing::judges(r->verdict, "supervisor faults")) << name;
      EXPECT_LE(r->peak_muscle_force_N, 2000.0);
      EXPECT_GT(r->min_wire_tension_N, 0.0);
      EXPECT_LE(r->peak_motor_torque_Nm, 2.5 + 1e-9);
    }
  }
}

// E4's brisk movement (40 -> 100 deg in 0.5 s) with feedback: each elbow muscle's request drops to the
// pretension within ~0.1 s while the nominal model misses its pressure threshold, and the 4 /s force
// trim alone let both wires sag to 16-18 N (the elbow's lowest wire 12.98 N, floor 20 N). The slack
// trim rate (controller.allocation.force_trim_slack_rate_1ps, 300 /s) keeps the wire >= 20 N (21.9 N);
// without it the same run fails that figure.
TEST(E4, BriskFeedbackKeepsTheElbowWiresAboveHalfThePretension) {
  ArmScenario s = test_support::shipped_right_arm();
  ASSERT_GT(s.controller.allocation.force_trim_slack_rate_1ps, 0.0);
  const GoniometerTrace t = synthesize_goniometer(s.goniometer, movement(s, "brisk"), s.seed);
  const GoniometerResult fb = run_goniometer(s, {t}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::judges(fb.verdict, "R_EFE lowest wire tension"));
  EXPECT_NEAR(fb.joints[0].min_wire_tension_N, fb.verdict.find("R_EFE lowest wire tension")->value, 1e-9);
  EXPECT_FALSE(testing::fails_on(fb.verdict, "R_EFE lowest wire tension")) << fb.verdict.failures();
  EXPECT_FALSE(testing::fails_on(fb.verdict, "R_EFE tracking RMS error")) << fb.verdict.failures();
  s.controller.allocation.force_trim_slack_rate_1ps = 0.0;
  const GoniometerResult before = run_goniometer(s, {t}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(before.verdict, "R_EFE lowest wire tension"));
}

// The start-up (issue 31): valves twice as fast as the controller's and the monitor's model, and
// muscles 15 % stronger, both faulted before the person moved (pressure_high on the shoulder's
// antagonist at 0.98 s; tension_floor on the shoulder's wire). The cause was the trim's slack rate
// winding up while the wires refilled from the tare's vent; it now waits for the refill. Both plants
// run the slow movement with no supervisor fault and meet every figure; the shipped plant too.
TEST(E4, FastValvesAndStrongMusclesStartWithoutAFault) {
  const ArmScenario shipped = test_support::shipped_right_arm();
  auto scaled = [&](double valve_time_scale, double muscle_strength_scale) {
    ArmScenario s = shipped;
    for (sim::PehaJointPlantParams& j : s.plant.actuators) {
      for (sim::MusclePlantParams* m : {&j.agonist, &j.antagonist}) {
        m->valve.dead_time_s *= valve_time_scale;
        m->valve.lag_s *= valve_time_scale;
        m->law.gain_N_per_Pa *= muscle_strength_scale;
      }
    }
    const GoniometerTrace t = synthesize_goniometer(s.goniometer, movement(s, "slow"), s.seed);
    return run_goniometer(s, {t}, GoniometerVariant::kFeedback, nullptr);
  };
  for (const auto& [valves, muscles] : {std::pair{0.5, 1.0}, std::pair{1.0, 1.15}, std::pair{1.0, 1.0}}) {
    const GoniometerResult r = scaled(valves, muscles);
    EXPECT_EQ(r.first_fault_flag, 0u) << "valves x" << valves << ", muscles x" << muscles;
    EXPECT_TRUE(r.within_limits) << "valves x" << valves << ", muscles x" << muscles << ": " << r.verdict.failures();
  }
}

// Issue 31 item 1: the PAMs' share of the torque behind E1's 5 Hz low-pass came ~30 ms after the
// valves' own lag; through each brisk stroke the 2.5 Nm motor saturated covering the difference, the
// elbow fell behind, caught up faster than the person and stopped hard, and the passive wrist whipped
// (nominal 321-377 deg/s; valves 1.5x slower: the supervisor tripped). With the share at 40 Hz (the
// valves are its low-pass) the nominal brisk wrist stays near 250 deg/s and the slower valves meet every figure.
TEST(E4, ThePamsCarryTheBriskStrokeSoTheMotorDoesNotSaturateAndWhipTheWrist) {
  const ArmScenario shipped = test_support::shipped_right_arm();
  ASSERT_GE(shipped.goniometer.pam_cutoff_Hz, 20.0);
  auto brisk = [&](double pam_cutoff_Hz, double valve_time_scale) {
    ArmScenario s = shipped;
    s.goniometer.pam_cutoff_Hz = pam_cutoff_Hz;
    for (sim::PehaJointPlantParams& j : s.plant.actuators) {
      for (sim::MusclePlantParams* m : {&j.agonist, &j.antagonist}) {
        m->valve.dead_time_s *= valve_time_scale;
        m->valve.lag_s *= valve_time_scale;
      }
    }
    const GoniometerTrace t = synthesize_goniometer(s.goniometer, movement(s, "brisk"), s.seed);
    return run_goniometer(s, {t}, GoniometerVariant::kFeedback, nullptr);
  };
  const GoniometerResult nominal = brisk(shipped.goniometer.pam_cutoff_Hz, 1.0);
  const GoniometerResult nominal_late = brisk(5.0, 1.0);
  ASSERT_EQ(nominal.passive.size(), 1u);
  EXPECT_TRUE(nominal.within_limits) << nominal.verdict.failures();
  EXPECT_LT(nominal.passive[0].value, 300.0);
  EXPECT_LT(nominal.passive[0].value, 0.9 * nominal_late.passive[0].value);
  const GoniometerResult slower = brisk(shipped.goniometer.pam_cutoff_Hz, 1.5);
  EXPECT_TRUE(slower.within_limits) << slower.verdict.failures();
  EXPECT_EQ(slower.first_fault_flag, 0u);
  const GoniometerResult slower_late = brisk(5.0, 1.5);
  EXPECT_NE(slower_late.first_fault_flag, 0u);
  EXPECT_TRUE(testing::fails_on(slower_late.verdict, "R_WFE passive peak speed")) << slower_late.verdict.failures();
}

// Issue 31: a person's 7 Hz, 3 deg tremor on the slow movement. The exoskeleton follows the voluntary
// movement: the tremor filter (goniometer.tremor) takes it out of the reading and the tracking is
// judged against the movement without it. Without the filter the tremor goes through the inverse
// dynamics: more than 1 Nm above 10 Hz (the figure fails) and the wrist shaken past 300 deg/s.
TEST(E4, APersonsTremorIsNotFollowed) {
  const ArmScenario shipped = test_support::shipped_right_arm();
  ASSERT_TRUE(shipped.goniometer.tremor.has_value());
  ArmScenario::Goniometer::Movement m = movement(shipped, "slow");
  m.tremor_amplitude_rad = models::deg_to_rad(3.0);
  m.tremor_frequency_Hz = 7.0;
  const GoniometerTrace t = synthesize_goniometer(shipped.goniometer, m, shipped.seed);
  const GoniometerResult filtered = run_goniometer(shipped, {t}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(filtered.within_limits) << filtered.verdict.failures();
  EXPECT_LT(filtered.joints[0].rms_error_deg, 3.0);  // against the voluntary movement
  ArmScenario unfiltered = shipped;
  unfiltered.goniometer.tremor.reset();
  const GoniometerResult shaking = run_goniometer(unfiltered, {t}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(shaking.verdict, "R_EFE torque command above 10 Hz (RMS)")) << shaking.verdict.failures();
  EXPECT_GT(shaking.joints[0].command_hf_rms_Nm, 1.0);
  ASSERT_EQ(shaking.passive.size(), 1u);
  EXPECT_GT(shaking.passive[0].value, 300.0);
  EXPECT_LT(filtered.passive[0].value, 0.6 * shaking.passive[0].value);
}

// The log keeps the single-elbow column names when one joint is driven (tools/plot_goniometer.py and
// the videos read them); with both elbows of the upper body driven each elbow's columns start with its
// log name, and every held joint (shoulders, named in goniometer.angles_deg) has its angle and gravity
// torque. Last, every io joint's sensors and commands for a replay: 11 columns per joint (8 sensors,
// 3 commands), less the 5 a driven joint's actuator block has already (load cells, commands).
TEST(E4, LogColumnsFollowTheDrivenAndHeldJoints) {
  const std::vector<std::string> one = goniometer_log_columns(test_support::shipped_right_arm());
  for (const char* c : {"person_elbow_deg", "plant_elbow_deg", "tau_elbow_cmd_Nm", "plant_sfe_deg", "tau_sfe_gravity_Nm",
                        "agonist_loadcell_N", "plant_tension_min_N", "angle_rad", "agonist_pressure_MPa", "sfe_angle_rad",
                        "wfe_tau_motor_cmd_Nm"}) {
    EXPECT_THAT(one, ::testing::Contains(std::string(c)));
  }
  // before the joint list: 2 + 8 + 2 + 11 (the actuator block: 7, then the muscles' contraction and
  // pressure for the video) + 1, then SFE, EFE, WFE
  EXPECT_EQ(one.size(), 24u + 3 * 11 - 5);
  EXPECT_EQ(one[23], "plant_tension_min_N");
  const ArmScenario upper = read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  const std::vector<std::string> both = goniometer_log_columns(upper);
  for (const char* c : {"r_efe_person_elbow_deg", "l_efe_person_elbow_deg", "r_efe_plant_elbow_deg", "l_efe_tau_motor_cmd_Nm",
                        "plant_r_saa_deg", "plant_l_sfe_deg", "tau_l_sfe_gravity_Nm", "r_efe_agonist_pressure_MPa", "l_saa_angle_rad"}) {
    EXPECT_THAT(both, ::testing::Contains(std::string(c)));
  }
  EXPECT_THAT(both, ::testing::Not(::testing::Contains(std::string("person_elbow_deg"))));
  EXPECT_EQ(both.size(), 2u + 2 * 8 + 4 * 2 + 2 * 11 + 1 + 8 * 11 - 2 * 5);
}

// Each driven joint's goniometer is its own sensor: the same movement, its own noise; the first is the
// one-joint trace of the same seed (the right arm's figures do not move).
TEST(E4, EachDrivenJointHasItsOwnGoniometer) {
  const ArmScenario upper = read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  const auto& m = movement(upper, "brisk");
  const std::vector<GoniometerTrace> t = synthesize_goniometers(upper.goniometer, m, 5);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].truth_rad, t[1].truth_rad);
  EXPECT_NE(t[0].measured_rad, t[1].measured_rad);
  EXPECT_EQ(t[0].measured_rad, synthesize_goniometer(upper.goniometer, m, 5).measured_rad);
  EXPECT_THROW(run_goniometer(upper, {t[0]}, GoniometerVariant::kFeedback, nullptr), std::invalid_argument);
}

// A recording in the documented format reads back as written; the reader rejects, naming the line
// and column, what would make the derivatives meaningless: wrong spacing, no unit, NaN, a reading
// outside the elbow's range, a missing column.
TEST(E4, GoniometerCsvRoundTripsAndRejectsBadRecordings) {
  const ArmScenario s = test_support::shipped_right_arm();
  const double lo = s.limits.joints[1].min_angle_rad, hi = s.limits.joints[1].max_angle_rad;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_e4_csv_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const GoniometerTrace t = synthesize_goniometer(s.goniometer, movement(s, "brisk"), 3);
  write_goniometer_csv(dir / "rec.csv", t);
  const GoniometerTrace back = read_goniometer_csv(dir / "rec.csv", 200.0, lo, hi);
  ASSERT_EQ(back.measured_rad.size(), t.measured_rad.size());
  for (std::size_t k = 0; k < t.measured_rad.size(); ++k) EXPECT_NEAR(back.measured_rad[k], t.measured_rad[k], models::deg_to_rad(1e-4));
  EXPECT_EQ(back.truth_rad, back.measured_rad);
  EXPECT_EQ(back.name, "rec");
  std::string first;
  std::ifstream rec(dir / "rec.csv");
  std::getline(rec, first);
  EXPECT_EQ(first, "t_s,elbow_angle_deg");  // the header first; the rate in the sidecar
  EXPECT_EQ(YAML::LoadFile((dir / "rec.csv.meta.json").string())["sample_rate_Hz"].as<double>(), 200.0);
  { std::ofstream(dir / "old.csv") << "# goniometer recording 'old', 200 Hz\nt_s,elbow_angle_deg\n0,40\n0.005,41\n"; }
  EXPECT_EQ(read_goniometer_csv(dir / "old.csv", 200.0, lo, hi).measured_rad.size(), 2u);  // older files: '#' lines skipped

  auto rejects = [&](const std::string& text, const std::string& message) {
    { std::ofstream(dir / "bad.csv") << text; }
    try {
      read_goniometer_csv(dir / "bad.csv", 200.0, lo, hi);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const calibration::DataError& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(message)) << text;
    }
  };
  rejects("t_s,elbow_angle_deg\n0,40\n0.01,41\n", "bad.csv:3:1: t_s steps by 0.01 s");
  rejects("t_s,elbow_angle\n0,40\n0.005,41\n", "bad.csv:1:2: column 'elbow_angle' has no unit");
  rejects("t_s,elbow_angle_deg\n0,40\n0.005,nan\n", "bad.csv:3:2: elbow_angle_deg: expected a finite number");
  rejects("t_s,elbow_angle_deg\n0,40\n0.005,170\n", "bad.csv:3:2: elbow_angle_deg = 170 is outside");
  rejects("t_s,elbow_angle_rad,elbow_angle_deg\n0,1,40\n", "column 'elbow_angle_deg' appears twice");
  rejects("t_s,knee_deg\n0,40\n", "missing column elbow_angle_deg or elbow_angle_rad");
  rejects("t_s,elbow_angle_deg\n0,40\n0.005\n", "bad.csv:3: expected 2 cells, found 1");
  std::filesystem::remove_all(dir);
}

// --goniometer-csv /dev/zero was read without bound; a device is refused at once, before any byte.
TEST(E4, GoniometerCsvRefusesADeviceAtOnce) {
  const ArmScenario s = test_support::shipped_right_arm();
  try {
    read_goniometer_csv("/dev/zero", 200.0, s.limits.joints[1].min_angle_rad, s.limits.joints[1].max_angle_rad);
    ADD_FAILURE() << "/dev/zero was accepted";
  } catch (const calibration::DataError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("/dev/zero: not a regular file (a device)"));
  }
}

// The CLI end to end on a recording: `peha run --experiment goniometer --goniometer-csv FILE` runs
// both variants on it and writes their logs and the summary; a bad recording exits 2.
TEST(E4, CliReplaysARecordedGoniometerFile) {
  const ArmScenario s = test_support::shipped_right_arm();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_e4_cli_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ArmScenario::Goniometer::Movement m = movement(s, "slow");
  m.repetitions = 1;
  m.name = "short";
  write_goniometer_csv(dir / "short.csv", synthesize_goniometer(s.goniometer, m, 1));
  auto run = [&](const std::string& args) {
    const std::string cmd = std::string(PEHA_BINARY) + " run --config " PEHA_SOURCE_DIR "/configs/right_arm.yaml --experiment goniometer "
                            "--no-plot --out " + dir.string() + " --name r " + args + " 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    std::string out;
    std::array<char, 4096> buf;
    while (fgets(buf.data(), buf.size(), pipe)) out += buf.data();
    return std::make_pair(WEXITSTATUS(pclose(pipe)), out);
  };
  const auto [code, out] = run("--goniometer-csv " + (dir / "short.csv").string());
  // Pure replay (open loop) fails its tracking figures: the paper's comparison, labelled, not judged.
  // The feedback variant passes every figure, the command above 10 Hz among them (exit 0).
  ASSERT_EQ(code, 0) << out;
  EXPECT_THAT(out, ::testing::HasSubstr("PASSED"));
  EXPECT_THAT(out, ::testing::HasSubstr("torque command above 10 Hz"));
  EXPECT_THAT(out, ::testing::HasSubstr("figures failed in the open-loop variant"));
  EXPECT_THAT(out, ::testing::HasSubstr("recording: "));
  EXPECT_TRUE(std::filesystem::exists(dir / "r" / "e4_short_open_loop.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "r" / "e4_short_feedback.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "r" / "summary.csv"));
  { std::ofstream(dir / "bad.csv") << "t_s,elbow_angle_deg\n0,40\n0.5,41\n"; }
  const auto [bad_code, bad_out] = run("--goniometer-csv " + (dir / "bad.csv").string());
  EXPECT_EQ(bad_code, 2) << bad_out;
  EXPECT_THAT(bad_out, ::testing::HasSubstr("bad.csv:3:1: t_s steps by 0.5 s"));
  std::filesystem::remove_all(dir);
}

// E4's verdict judges every joint and the command (issue 31): each held joint's excursion
// (goniometer.thresholds.max_held_excursion_deg), each passive joint's peak speed (the wrist at its
// constant pressure), and each driven joint's torque command above 10 Hz (RMS) and the smoothing's
// delay (cross-correlation against the un-smoothed command). Each figure is shown to pass and to fail.
// The shipped reference and impedance (docs/right-arm.md, E4) pass every one on both movements
// (0.06 / 0.09 Nm above 10 Hz, the wrist ~56 / 372 deg/s, the shoulder ~0.3 / 1.6 deg). A late
// inertial term (jerk density 1 instead of 25: quiet, 0.04 Nm on the slow movement) whips the wrist
// past 500 deg/s and swings the shoulder at the brisk pace, and lags pure replay ~110 ms; without
// the shoulder's hold impedance the forearm's reaction swings it; an un-smoothed reference (the raw
// derivatives) and the damping on the controller's own 20 Hz rate each fail the command figure.
TEST(E4, EveryHeldAndPassiveJointAndTheCommandAreJudged) {
  ArmScenario s = test_support::shipped_right_arm();
  const GoniometerTrace slow = synthesize_goniometer(s.goniometer, movement(s, "slow"), s.seed);
  const GoniometerTrace brisk = synthesize_goniometer(s.goniometer, movement(s, "brisk"), s.seed);
  const GoniometerResult nominal = run_goniometer(s, {slow}, GoniometerVariant::kFeedback, nullptr);
  const GoniometerResult fast = run_goniometer(s, {brisk}, GoniometerVariant::kFeedback, nullptr);
  for (const GoniometerResult* r : {&nominal, &fast}) {
    for (const char* figure : {"R_SFE held excursion", "R_WFE passive peak speed", "R_EFE torque command above 10 Hz (RMS)",
                               "R_EFE torque command delay (smoothing)"}) {
      EXPECT_TRUE(testing::judges(r->verdict, figure)) << figure;
      EXPECT_FALSE(testing::fails_on(r->verdict, figure)) << r->verdict.failures();
    }
    ASSERT_EQ(r->held.size(), 1u);
    EXPECT_EQ(r->held[0].joint, "R_SFE");
    EXPECT_NEAR(r->held[0].value, r->joints[0].held_excursion_deg, 1e-9);
    EXPECT_GT(r->joints[0].command_delay_s, 0.0);  // the smoothing does delay it, by less than 50 ms
  }

  ArmScenario late = s;  // the inertial term ~60 ms later: quiet, but a late push at each stroke
  late.goniometer.acceleration_jerk_density_rad2ps5 = 1.0;
  const GoniometerResult quiet = run_goniometer(late, {slow}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_LT(quiet.joints[0].command_hf_rms_Nm, nominal.joints[0].command_hf_rms_Nm);
  const GoniometerResult whip = run_goniometer(late, {brisk}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(whip.verdict, "R_WFE passive peak speed")) << whip.verdict.failures();
  EXPECT_TRUE(testing::fails_on(whip.verdict, "R_SFE held excursion")) << whip.verdict.failures();
  const GoniometerResult lagging = run_goniometer(late, {brisk}, GoniometerVariant::kOpenLoop, nullptr);
  EXPECT_TRUE(testing::fails_on(lagging.verdict, "R_EFE torque command delay (smoothing)")) << lagging.verdict.failures();

  // The shoulder on its inverse-dynamics row alone, its PAMs' share behind a 5 Hz low-pass (E1's): the
  // forearm's reaction reaches it late and swings it. With the PAMs' share at the arm's 40 Hz the row
  // alone holds it within 0.2 deg at the brisk pace; the impedance is what holds it when the row is late.
  ArmScenario unheld = s;
  unheld.goniometer.hold_stiffness_Nm_per_rad = unheld.goniometer.hold_damping_Nms_per_rad = 0.0;
  unheld.goniometer.pam_cutoff_Hz = 5.0;
  const GoniometerResult swinging = run_goniometer(unheld, {brisk}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(swinging.verdict, "R_SFE held excursion")) << swinging.held[0].value << " deg\n" << swinging.verdict.failures();

  ArmScenario raw = s;  // no smoothing: the derivatives and the command pass (almost) everything
  raw.goniometer.rate_cutoff_Hz = 0.45 * raw.goniometer.sample_rate_Hz;
  raw.goniometer.acceleration_jerk_density_rad2ps5 = 1e5;
  raw.goniometer.command_cutoff_Hz = 0.45 / raw.period_s;
  const GoniometerResult noisy = run_goniometer(raw, {slow}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(noisy.verdict, "R_EFE torque command above 10 Hz (RMS)")) << noisy.verdict.failures();

  ArmScenario lagged_damping = s;  // the damping on a rate as late as the controller's own
  lagged_damping.goniometer.encoder_velocity_cutoff_Hz = 20.0;
  const GoniometerResult buzzing = run_goniometer(lagged_damping, {brisk}, GoniometerVariant::kFeedback, nullptr);
  EXPECT_TRUE(testing::fails_on(buzzing.verdict, "R_EFE torque command above 10 Hz (RMS)")) << buzzing.verdict.failures();
}

}  // namespace
}  // namespace peha::experiments

namespace peha::experiments {
namespace {

/// Figures of an E4 feedback run from the operator's recovery on (plant truth; the wrist's encoder).
struct AfterReArm {
  double recovered_s = -1, elbow_degps = 0, shoulder_degps = 0, wrist_degps = 0, lowest_wire_N = 1e9, final_gap_deg = 0;
};

/// E4 at `pace` with the state packets lost for 1 s from `at_s` (the person keeps moving), the
/// unattended operator recovering 0.5 s after they return; `edit` changes the scenario first.
AfterReArm state_loss_in_e4(const std::string& pace, double at_s, const std::function<void(ArmScenario&)>& edit = {}) {
  ArmScenario s = test_support::shipped_right_arm();
  if (edit) edit(s);
  const GoniometerTrace t = synthesize_goniometers(s.goniometer, movement(s, pace), s.seed).front();
  const double outage_s = 1.0, duration_s = goniometer_run_duration_s(s, t);
  s.faults.push_back(sim::parse_fault_spec(fmt::format("state_loss@{}:R_EFE={}", at_s, outage_s), arm_joint_names(s), duration_s));
  s.lifecycle.recover_after_s = outage_s + 0.5;
  runtime::CsvLog log(goniometer_log_columns(s), static_cast<std::size_t>(duration_s / s.period_s) + 2);
  const GoniometerResult r = run_goniometer(s, {t}, GoniometerVariant::kFeedback, &log);
  AfterReArm a;
  for (const runtime::LifecycleEvent& e : r.lifecycle) {
    if (e.transition == runtime::Transition::kRecovered && a.recovered_s < 0) a.recovered_s = e.t_s;
  }
  const std::size_t time = log.column("t_s"), elbow = log.column("plant_elbow_deg"), shoulder = log.column("plant_sfe_deg"),
                    wrist = log.column("wfe_angle_rad"), tension = log.column("plant_tension_min_N"), person = log.column("person_elbow_deg");
  for (std::size_t k = 1; a.recovered_s >= 0 && k < log.rows(); ++k) {
    const double t_s = log.at(k, time), dt = t_s - log.at(k - 1, time);
    if (t_s < a.recovered_s || !(dt > 0)) continue;
    a.elbow_degps = std::max(a.elbow_degps, std::abs(log.at(k, elbow) - log.at(k - 1, elbow)) / dt);
    a.shoulder_degps = std::max(a.shoulder_degps, std::abs(log.at(k, shoulder) - log.at(k - 1, shoulder)) / dt);
    a.wrist_degps = std::max(a.wrist_degps, models::rad_to_deg(std::abs(log.at(k, wrist) - log.at(k - 1, wrist))) / dt);
    if (t_s > a.recovered_s + s.lifecycle.recovery_ramp_s) a.lowest_wire_N = std::min(a.lowest_wire_N, log.at(k, tension));
    if (t_s > duration_s - 1.0) a.final_gap_deg = std::max(a.final_gap_deg, std::abs(log.at(k, elbow) - log.at(k, person)));
  }
  std::printf("%s, state loss at %.1f s: re-armed at %.3f s; then elbow %.0f deg/s, shoulder %.0f deg/s, wrist %.0f deg/s, lowest wire "
              "%.1f N after the ramp; in the last second the elbow within %.1f deg of the person\n",
              pace.c_str(), at_s, a.recovered_s, a.elbow_degps, a.shoulder_degps, a.wrist_degps, a.lowest_wire_N, a.final_gap_deg);
  return a;
}

// Issue 29 item 2 in E4: after an outage the person has moved on. At the operator's recovery the
// allocation restarts from the pressures measured now, and E4's reference starts where the elbow is
// and moves toward the person at goniometer.rejoin's 30 deg/s, at most 5 deg ahead of the elbow,
// until it reaches the person at a pause after the recovery's ramp (the held shoulder's posture
// closes its gap the same way). A 1 s loss of the state packets in the slow movement, at three
// moments: no lunge after the re-arm (before, the impedance pulled the elbow to the person's angle:
// 214-384 deg/s, the shoulder 61-111 deg/s, the wrist 288-453 deg/s), no slack wire after the ramp,
// and the elbow with the person again by the end. A rejoin as fast and as far ahead as the reader
// allows (180 deg/s, 30 deg) is that lunge again.
TEST(E4, AStateLossMidMovementReArmsWithoutALungeAndRejoinsThePerson) {
  for (double at_s : {6.0, 7.0, 8.0}) {
    const AfterReArm a = state_loss_in_e4("slow", at_s);
    ASSERT_GT(a.recovered_s, at_s + 1.0) << at_s;  // after the samples came back
    EXPECT_LT(a.elbow_degps, 120.0) << at_s;
    EXPECT_LT(a.shoulder_degps, 30.0) << at_s;
    EXPECT_LT(a.wrist_degps, 250.0) << at_s;
    EXPECT_GT(a.lowest_wire_N, 0.5 * 20.0) << at_s;
    EXPECT_LT(a.final_gap_deg, 10.0) << at_s;
  }
  const AfterReArm lunge = state_loss_in_e4("slow", 6.0, [](ArmScenario& s) {
    s.goniometer.rejoin_rate_radps = models::deg_to_rad(180.0);
    s.goniometer.rejoin_lead_rad = models::deg_to_rad(30.0);
  });
  EXPECT_GT(lunge.elbow_degps, 120.0);
}

}  // namespace
}  // namespace peha::experiments
