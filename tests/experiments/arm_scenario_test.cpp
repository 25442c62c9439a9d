#include "peha/safety/limited_backend.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth.hpp"

#include "peha/experiments/robustness/robustness.hpp"
#include "peha/models/units.hpp"

#include "../support/alloc_counter.hpp"
#include "../support/edited_config.hpp"
#include "../support/verdict_checks.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace peha::experiments {
namespace {

// E3 on the simulated right arm (the paper's claim): released in each posture, including (0, 0) where
// the shoulder carries the most, the arm stays - under 0.5 deg in the 10 s after release at both
// joints, with feed-forward J^T G only. The verdict fails two kinds of figure, both real: the wrist,
// held at a constant 0.25 MPa (no allocation keeps its wires taut), lets its wire drop to ~15 N, below
// the floor of 0.5 x the 40 N pretension; and the static torque error, because the shipped plant is
// 8-12 % heavier than the controller's model and the cable friction holds the difference
// (docs/right-arm.md).
TEST(E3, ArmStaysInEveryPostureWhereTheOperatorLeavesIt) {
  const ArmScenario s = test_support::shipped_right_arm();
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.postures.size(), s.postures.size());
  for (const std::string& f : testing::failed_figures(r.verdict)) {
    if (f.ends_with("|static torque error|")) continue;
    EXPECT_EQ(f, "R_WFE lowest wire tension") << r.verdict.failures();
  }
  EXPECT_TRUE(testing::judges(r.verdict, "raised_flexed R_SFE |drift|"));
  EXPECT_TRUE(testing::judges(r.verdict, "supervisor faults"));  // on, and no false alarm (it would fail above)
  EXPECT_TRUE(testing::judges(r.verdict, "elbow_90 R_EFE distance to a stop"));
  EXPECT_LE(r.peak_muscle_force_N, 2000.0);
  EXPECT_GT(r.min_wire_tension_N, 0.0);
  for (const PostureResult& p : r.postures) {
    EXPECT_LT(p.joints[0].max_excursion_deg, 0.5) << p.name;
    EXPECT_LT(p.joints[1].max_excursion_deg, 0.5) << p.name;
    // The operator really moved the arm there (within the reach of their 30 Nm hands).
    EXPECT_NEAR(p.joints[0].released_deg, p.joints[0].target_deg, 5.0) << p.name;
    EXPECT_NEAR(p.joints[1].released_deg, p.joints[1].target_deg, 5.0) << p.name;
  }
}

// The static torque error at rest is what the friction holds (plant truth): with the body file's
// anthropometric prior (the nominal arm, not the shipped identification) it is the controller's gravity
// model error (the plant's bodies are 8-12 % heavier), posture by posture, and it fails the 5 %
// threshold at the elbow; a controller given the plant's own bodies passes it everywhere (what is left:
// the pulleys' 1 % and the allocation's rounding).
TEST(E3, StaticTorqueErrorIsTheGravityTheControllerDoesNotKnow) {
  ArmScenario s = test_support::shipped_right_arm();
  s.controller.arm = s.nominal_arm;  // the prior, before identification
  const PosturesResult nominal = run_postures(s, nullptr);
  int judged = 0;
  for (const PostureResult& p : nominal.postures) {
    for (int j = 0; j < 2; ++j) {
      if (std::abs(p.joints[j].gravity_torque_Nm) < s.verdict.min_gravity_torque_Nm) continue;
      ++judged;
      EXPECT_NEAR(p.joints[j].static_torque_error_pct, p.joints[j].model_gravity_error_pct, 1.5) << p.name << " joint " << j;
      EXPECT_LT(p.joints[j].static_torque_error_pct, -5.0) << p.name << " joint " << j;  // the plant is heavier
    }
  }
  EXPECT_GE(judged, 8);
  EXPECT_TRUE(testing::fails_on(nominal.verdict, "elbow_90 R_EFE |static torque error|")) << nominal.verdict.failures();

  s.controller.arm = s.plant.model;  // the controller told the truth about the bodies
  const PosturesResult told = run_postures(s, nullptr);
  for (const PostureResult& p : told.postures) {
    for (int j = 0; j < 2; ++j) {
      if (std::abs(p.joints[j].gravity_torque_Nm) < s.verdict.min_gravity_torque_Nm) continue;
      EXPECT_LT(std::abs(p.joints[j].static_torque_error_pct), 3.0) << p.name << " joint " << j;
    }
  }
  for (const std::string& f : testing::failed_figures(told.verdict)) EXPECT_EQ(f, "R_WFE lowest wire tension") << told.verdict.failures();
}

// The review's case: an unknown 1 kg in the hand (the controller is not told) and no position
// feedback - the arm must move (physics forbids holding it), and E3's verdict says so: the drift,
// excursion and supervisor figures fail instead of "OK".
TEST(E3, UnknownPayloadInTheHandFailsTheDriftFigures) {
  ArmScenario s = test_support::shipped_right_arm();
  PlantVariant v;
  v.extra_payload_kg = 1.0;
  s.plant = arm_variant_plant(s, v);
  const PosturesResult r = run_postures(s, nullptr);
  EXPECT_FALSE(r.within_limits);
  // elbow_90: the elbow sinks ~79 deg after the release, and the shoulder with it (~7 deg); at
  // `horizontal` the stiction band still covers the extra 1 kg.
  EXPECT_TRUE(testing::fails_on(r.verdict, "elbow_90 R_EFE |drift|")) << r.verdict.failures();
  EXPECT_TRUE(testing::fails_on(r.verdict, "elbow_90 R_EFE max excursion")) << r.verdict.failures();
  EXPECT_TRUE(testing::fails_on(r.verdict, "elbow_90 R_SFE |drift|")) << r.verdict.failures();
  EXPECT_FALSE(testing::fails_on(r.verdict, "horizontal R_SFE |drift|"));
  // Every static torque error figure fails (14-38 %): the verdict says the arm is not compensated.
  EXPECT_TRUE(testing::fails_on(r.verdict, "raised_flexed R_EFE |static torque error|")) << r.verdict.failures();
  // The wires stay taut while it sinks (the trim's slack rate, allocation.force_trim_slack_rate_1ps):
  // before it, the shoulder's agonist wire went below the tension floor at 58.6 s and the supervisor
  // latched and descended; now nothing implausible happens at the backend boundary, and no joint
  // reaches a stop.
  EXPECT_FALSE(testing::fails_on(r.verdict, "supervisor faults")) << r.verdict.failures();
  EXPECT_FALSE(testing::fails_on(r.verdict, "distance to a stop")) << r.verdict.failures();
}

// The actuators as peha sizes them (docs/models.md): peak pulley torques at the 2000 N force limit of
// about 100 Nm (shoulder) and 76 Nm (elbow); the wrist's DMSP-10 pair, no motor, held at 0.25 MPa.
TEST(RightArmScenario, ActuatorsAreSizedAsSpecified) {
  const ArmScenario s = test_support::shipped_right_arm();
  ASSERT_EQ(s.controller.joints.size(), 3u);
  EXPECT_NEAR(2000.0 * s.controller.joints[0].actuator.pulley_radius_m, 100.0, 1e-9);
  EXPECT_NEAR(2000.0 * s.controller.joints[1].actuator.pulley_radius_m, 76.0, 1e-9);
  EXPECT_FALSE(s.controller.joints[2].actuator.has_motor);
  EXPECT_EQ(s.controller.joints[2].mode, control::ArmJointMode::kHoldPressure);
  EXPECT_DOUBLE_EQ(s.controller.joints[2].hold_pressure_Pa, 0.25e6);
}

// The arm's control step (J^T G + three allocations + limits) allocates nothing.
TEST(ArmController, StepAllocatesNothing) {
  const ArmScenario s = test_support::shipped_right_arm();
  sim::ArmBackend plant(s.plant);
  control::ArmController controller(s.controller);
  safety::LimitedBackend limited(plant, s.limits, arm_joint_models(controller.model()));
  limited.activate();
  io::SensorState state;
  io::Command command;
  std::size_t n = 0;
  for (int k = 0; k < 2000; ++k) {
    n += testing::allocations_during([&] {  // read (a copy of the truth), control, limits, one plant period
      limited.read(state);
      controller.update(state, command);
      limited.write(command);
    });
  }
  EXPECT_EQ(n, 0u);
}

// The arm runs the same joint step as E1's controller (control/joint_step.hpp), the wire-creep
// estimator included: on, it runs on every allocated joint once the start-up is over (its clock of
// taut wires runs; the hanging arm's operating points lie outside the grid E1's rig taught it, so it
// takes no reference here), not on the wrist's constant-pressure hold; still allocation-free. Off
// (the shipped default) nothing of it runs.
TEST(ArmController, RunsTheCreepEstimatorOnEveryAllocatedJointWhenOn) {
  ArmScenario s = test_support::shipped_right_arm();
  s.controller.creep.enabled = true;
  sim::ArmBackend plant(s.plant);
  control::ArmController controller(s.controller);
  control::ArmController shipped_controller(test_support::shipped_right_arm().controller);
  safety::LimitedBackend limited(plant, s.limits, arm_joint_models(controller.model()));
  limited.activate();
  io::SensorState state;
  io::Command command, shipped_command;
  std::size_t n = 0;
  for (int k = 0; k < 5000; ++k) {
    limited.read(state);
    n += testing::allocations_during([&] { controller.update(state, command); });
    shipped_controller.update(state, shipped_command);
    limited.write(command);
  }
  EXPECT_EQ(n, 0u);
  for (std::size_t j = 0; j < 2; ++j) {  // shoulder, elbow: taut since the start-up ended (~3 s)
    EXPECT_GT(controller.diagnostics()[j].creep.tension_time_s, 1.0) << j;
    EXPECT_EQ(shipped_controller.diagnostics()[j].creep.tension_time_s, 0.0) << j;
  }
  EXPECT_EQ(controller.diagnostics()[2].creep.tension_time_s, 0.0);  // the wrist's hold
}

}  // namespace
}  // namespace peha::experiments

namespace peha::experiments {
namespace {

// E6 (the paper's open question): on the locked elbow, a 2 Nm torque sine (within the motor's
// 2.5 Nm rating) is delivered with unit gain at low frequency by both; PAM-only rolls off (valve
// dead time, lag and rate limit) with its -3 dB point between 2 and 20 Hz, while the hybrid joint's
// motor keeps the gain within 10 % up to the highest frequency tested (30 Hz).
TEST(E6, HybridJointHasTheWiderTorqueBandwidth) {
  const ArmScenario s = test_support::shipped_right_arm();
  const BandwidthResult pam = run_bandwidth(s, /*hybrid=*/false);
  const BandwidthResult hybrid = run_bandwidth(s, /*hybrid=*/true);
  EXPECT_NEAR(pam.bode.front().gain, 1.0, 0.1);
  EXPECT_NEAR(hybrid.bode.front().gain, 1.0, 0.1);
  ASSERT_TRUE(pam.reached_3dB);
  EXPECT_GT(pam.bandwidth_3dB_Hz, 2.0);
  EXPECT_LT(pam.bandwidth_3dB_Hz, 20.0);
  EXPECT_FALSE(hybrid.reached_3dB);
  for (const BodePoint& p : hybrid.bode) EXPECT_NEAR(p.gain, 1.0, 0.1) << p.frequency_Hz << " Hz";
  for (const BandwidthResult* r : {&pam, &hybrid}) {
    // The one verdict: every figure but the wrist's tension floor (see E3) holds.
    for (const std::string& f : testing::failed_figures(r->verdict)) EXPECT_EQ(f, "R_WFE lowest wire tension") << r->verdict.failures();
    EXPECT_TRUE(testing::judges(r->verdict, "supervisor faults"));  // on, and no false alarm
    EXPECT_LE(r->peak_muscle_force_N, 2000.0);
    EXPECT_GT(r->min_wire_tension_N, 0.0);
    EXPECT_LE(r->peak_motor_torque_Nm, 2.5);
  }
  EXPECT_EQ(pam.peak_motor_torque_Nm, 0.0);  // PAM-only really has no motor
}

// E6 measured after the cable (at the joint): the wires' stick band (capstan static friction, about
// e^+-0.25 of the tension on the elbow) swallows the muscles' small 2 Nm sine on a locked joint, so
// below 1 Hz neither variant delivers it there; what passes at high frequency is the hybrid's motor.
// With no cable friction in the plant the torque after the cable is the muscle-side torque.
TEST(E6, TorqueAfterTheCableLosesWhatTheCablesStictionHolds) {
  ArmScenario s = test_support::shipped_right_arm();
  s.bandwidth.frequencies_Hz = {0.2, 1.0, 30.0};
  const BandwidthResult pam = run_bandwidth(s, /*hybrid=*/false);
  const BandwidthResult hybrid = run_bandwidth(s, /*hybrid=*/true);
  ASSERT_EQ(pam.bode_at_joint.size(), 3u);
  EXPECT_LT(pam.bode_at_joint[0].gain, 0.2);
  EXPECT_LT(hybrid.bode_at_joint[0].gain, 0.2);
  EXPECT_NEAR(hybrid.bode_at_joint[2].gain, 1.0, 0.15);  // the motor, at the joint
  EXPECT_LT(pam.bode_at_joint[2].gain, 0.1);
  EXPECT_FALSE(pam.reached_3dB_at_joint);
  EXPECT_DOUBLE_EQ(pam.bandwidth_3dB_at_joint_Hz, 0.2);  // "< 0.2 Hz"

  for (sim::MusclePlantParams* m : {&s.plant.actuators[1].agonist, &s.plant.actuators[1].antagonist}) {
    m->cable.static_friction = m->cable.kinetic_friction = 0.0;
  }
  const BandwidthResult frictionless = run_bandwidth(s, /*hybrid=*/false);
  for (std::size_t i = 0; i < frictionless.bode.size(); ++i) {
    EXPECT_NEAR(frictionless.bode_at_joint[i].gain, frictionless.bode[i].gain, 1e-6) << frictionless.bode[i].frequency_Hz << " Hz";
  }
}

// E6 at the joint can fail: the hybrid's -3 dB band there (about 2 to > 30 Hz) is its motor's, so a
// hybrid whose plant has no motor (the controller still splits and commands one) falls to the
// PAM-only figure - no band at the joint - and on the muscle side to at most PAM-only's bandwidth (its
// PAMs get only the low-passed share).
TEST(E6, HybridWithoutItsMotorFallsToThePamOnlyFigureAtTheJoint) {
  ArmScenario s = test_support::shipped_right_arm();
  s.bandwidth.frequencies_Hz = {0.2, 1.0, 3.0, 10.0, 30.0};
  const BandwidthResult pam = run_bandwidth(s, /*hybrid=*/false);
  const BandwidthResult hybrid = run_bandwidth(s, /*hybrid=*/true);
  EXPECT_TRUE(pam.pass_band_at_joint.empty()) << pam.pass_band_at_joint.low_Hz << " to " << pam.pass_band_at_joint.high_Hz;
  ASSERT_FALSE(hybrid.pass_band_at_joint.empty());
  EXPECT_GT(hybrid.pass_band_at_joint.low_Hz, 1.0);  // below it the cables' stick band: high-pass
  EXPECT_LT(hybrid.pass_band_at_joint.low_Hz, 3.0);
  EXPECT_TRUE(hybrid.pass_band_at_joint.open_high);  // the motor still passes at 30 Hz
  const char* figure = "hybrid torque band at the joint, upper -3 dB edge";
  ASSERT_NE(hybrid.verdict.find(figure), nullptr);  // judged (configs/right_arm.yaml: >= 10 Hz)
  EXPECT_TRUE(hybrid.verdict.find(figure)->passed());
  EXPECT_EQ(pam.verdict.find(figure), nullptr);

  s.plant.actuators[static_cast<std::size_t>(s.bandwidth.joint)].has_motor = false;
  const BandwidthResult motorless = run_bandwidth(s, /*hybrid=*/true);
  EXPECT_EQ(motorless.peak_motor_torque_Nm, 0.0);
  EXPECT_TRUE(motorless.pass_band_at_joint.empty()) << motorless.pass_band_at_joint.low_Hz << " to " << motorless.pass_band_at_joint.high_Hz;
  for (std::size_t i = 0; i < motorless.bode_at_joint.size(); ++i) {
    EXPECT_LT(motorless.bode_at_joint[i].gain, 0.5) << motorless.bode_at_joint[i].frequency_Hz << " Hz";
  }
  EXPECT_LE(motorless.bandwidth_3dB_Hz, pam.bandwidth_3dB_Hz);
  ASSERT_NE(motorless.verdict.find(figure), nullptr);
  EXPECT_FALSE(motorless.verdict.find(figure)->passed());  // and E6's exit code says so
  EXPECT_FALSE(motorless.within_limits);
}

// The -3 dB band: the widest run at or above 1/sqrt(2), edges interpolated in log frequency, open at
// the sweep's ends; a high-pass has a lower edge, a response below -3 dB everywhere has none.
TEST(E6, PassBandFindsTheWidestRunAboveMinus3dB) {
  const double k = 1.0 / std::sqrt(2.0);
  const PassBand high_pass = pass_band_3dB({{1.0, 0.0, 0}, {4.0, 2.0 * k, 0}, {10.0, 1.0, 0}, {30.0, 1.0, 0}});
  EXPECT_NEAR(high_pass.low_Hz, 2.0, 1e-9);  // halfway in log between 1 and 4 Hz
  EXPECT_FALSE(high_pass.open_low);
  EXPECT_TRUE(high_pass.open_high);
  EXPECT_DOUBLE_EQ(high_pass.high_Hz, 30.0);
  const PassBand two_runs = pass_band_3dB({{1.0, 1.0, 0}, {2.0, 0.1, 0}, {5.0, 1.0, 0}, {50.0, 1.0, 0}, {100.0, 0.1, 0}});
  EXPECT_GT(two_runs.low_Hz, 2.0);  // the wider run (5-50 Hz and a bit), not the one at 1 Hz
  EXPECT_LT(two_runs.high_Hz, 100.0);
  EXPECT_TRUE(pass_band_3dB({{1.0, 0.5, 0}, {10.0, 0.6, 0}}).empty());
}

// E6's verdict is the envelope with each muscle's own ceiling from the configuration (it used a
// literal 2000 N): with the elbow antagonist's ceiling configured below what it delivers, E6 fails
// and names it. Two frequencies keep the run short.
TEST(E6, VerdictUsesEachMusclesConfiguredCeiling) {
  ArmScenario s = test_support::shipped_right_arm();
  s.bandwidth.frequencies_Hz = {1.0, 5.0};
  const BandwidthResult nominal = run_bandwidth(s, true);
  EXPECT_FALSE(testing::fails_on(nominal.verdict, "R_EFE antagonist peak force"));
  const safety::Check* c = nominal.verdict.find("R_EFE antagonist peak force");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->limit, 630.0);
  // The controller keeps its commands under its own ceiling; what the figure catches is force it did
  // not command: a plant started out of its equilibrium (not settled, ArmPlantParams::settle_s) jolts
  // the antagonist at start-up past a ceiling halved to what the settled run peaks at.
  s.controller.joints[1].actuator.antagonist.max_force_N = 0.5 * c->value;
  s.plant.settle_s = 0.0;
  const BandwidthResult low = run_bandwidth(s, true);
  EXPECT_TRUE(testing::fails_on(low.verdict, "R_EFE antagonist peak force")) << low.verdict.failures();
}

}  // namespace
}  // namespace peha::experiments

namespace peha::experiments {
namespace {

// The arm's start-up tare (off in the shipped scenario, docs/right-arm.md): with tare_s > 0 the
// controller vents the shoulder and elbow, averages their load cells and takes that as the offset -
// a +40 N bias on every load cell is measured as 40 N (within the noise and the vented muscles' last
// newtons) on both muscles of both joints; the wrist (held at constant pressure) is not tared.
TEST(E3, StartupTareMeasuresTheLoadCellsOffsets) {
  ArmScenario s = test_support::shipped_right_arm();
  s.controller.allocation.loadcell_check.tare_s = 0.5;
  PlantVariant v;
  v.loadcell_bias_N = 40.0;
  s.plant = arm_variant_plant(s, v);
  sim::ArmBackend plant(postures_plant_params(s));
  control::ArmController controller(s.controller);
  safety::LimitedBackend limited(plant, s.limits, arm_joint_models(controller.model()));
  limited.activate();
  io::SensorState state;
  io::Command command;
  for (int k = 0; k < 1500; ++k) {  // 1.5 s: vent 0.4 s, tare 0.5 s, then compensating
    limited.read(state);
    controller.update(state, command);
    if (k < 800) {
      EXPECT_NE(controller.startup_phase(), control::StartupPhase::kCompensating) << k;
      EXPECT_TRUE(controller.wires_slack_on_purpose(state.time_s));
    }
    limited.write(command);
  }
  EXPECT_EQ(controller.startup_phase(), control::StartupPhase::kCompensating);
  EXPECT_NEAR(controller.compensating_since_s(), 0.9, 0.01);
  for (std::size_t j = 0; j < 2; ++j) {
    for (int m = 0; m < 2; ++m) EXPECT_NEAR(controller.loadcell_offset_N(j, m), 40.0, 3.0) << j << " " << m;
  }
  EXPECT_EQ(controller.loadcell_offset_N(2, 0), 0.0);
}

// The arm's start-up (vent, tare and the refill under the operator's hands, until the operator lets go
// at 2 s) is judged on every compensated joint. The plant starts at rest, as a real arm at power-on
// (ArmPlantParams::settle_s): the shoulder moves 0.24 deg at 4.1 deg/s. A plant started out of its
// equilibrium (the pressures and slack of the file, no settling) throws the shoulder at about 28 deg/s
// in its first 50 ms: the figure fails.
TEST(E3, TheStartUpMovesNoJointMoreThanTwoDegreesOrTenDegreesPerSecond) {
  ArmScenario s = test_support::shipped_right_arm();
  s.postures_stop_s = 5.0;
  const PosturesResult r = run_postures(s, nullptr);
  for (const char* joint : {"R_SFE", "R_EFE"}) {
    const safety::Check* excursion = r.verdict.find(std::string(joint) + " start-up excursion");
    const safety::Check* speed = r.verdict.find(std::string(joint) + " start-up speed");
    ASSERT_NE(excursion, nullptr) << joint;
    ASSERT_NE(speed, nullptr) << joint;
    EXPECT_LT(excursion->value, 1.0) << joint;
    EXPECT_LT(speed->value, 7.0) << joint;
    EXPECT_TRUE(excursion->passed() && speed->passed()) << joint;
  }
  ArmScenario jolted = s;
  jolted.plant.settle_s = 0.0;
  const safety::Check* speed = run_postures(jolted, nullptr).verdict.find("R_SFE start-up speed");
  ASSERT_NE(speed, nullptr);
  EXPECT_GT(speed->value, 15.0);
  EXPECT_FALSE(speed->passed());
}

// A load cell whose zero is 20 N below code 0 reads 0 vented: the tare cannot measure it, and the
// monitor latches loadcell_zero in the vent (0.12 s) -> hold on the pressures found. The operator lets
// go of the arm only when the run is ready (ArmBackend::keep_hands), so the arm stays in the hands
// that held it from t = 0: the shoulder moves < 1 deg in 10 s. A careless operator who lets go by the
// clock drops it onto the vented muscles (measured: 74 deg at the first release).
TEST(E3, AZeroBelowCodeZeroAtPowerOnIsCaughtVentedAndTheOperatorKeepsHoldingTheArm) {
  ArmScenario s = test_support::shipped_right_arm();
  s.postures_stop_s = 10.0;  // the first release at 7.5 s
  s.faults = {sim::parse_fault_spec("loadcell_bias@0:R_SFE.agonist=-20", arm_joint_names(s), postures_duration_s(s))};
  auto shoulder_span_deg = [](const PosturesResult& r) {
    const safety::Check* lo = r.verdict.find("R_SFE lowest angle");
    const safety::Check* hi = r.verdict.find("R_SFE highest angle");
    return lo && hi ? hi->value - lo->value : 1e9;
  };
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.faults, 1u) << r.fault_reason;
  EXPECT_EQ(r.fault_reason.find("loadcell_zero joint 0 agonist"), 0u) << r.fault_reason;
  EXPECT_LT(shoulder_span_deg(r), 1.0);
  ArmScenario careless = s;
  careless.plant.operator_hands.waits_until_ready = false;
  EXPECT_GT(shoulder_span_deg(run_postures(careless, nullptr)), 20.0);
}

// controller_nan (sim/plant_faults.hpp) is E3's step's part of the fault injection: from its time the
// command on its joint carries a NaN, which the plausibility stage sees in the same cycle and answers
// with hold. The run is cut at 10 s (postures_stop_s): the fault is 1 s after the first release.
TEST(E3, AControllerNanOnTheElbowIsCaughtInItsCycleAndHeld) {
  ArmScenario s = test_support::shipped_right_arm();
  s.postures_stop_s = 10.0;
  EXPECT_DOUBLE_EQ(postures_duration_s(s), 10.0);
  s.faults = {sim::parse_fault_spec("controller_nan@8.5:R_EFE", arm_joint_names(s), postures_duration_s(s))};
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.faults, 1u) << r.fault_reason;
  EXPECT_EQ(r.fault_flags, static_cast<std::uint32_t>(safety::kFaultNonFiniteCommand));
  EXPECT_NE(r.fault_reason.find("nonfinite_command joint 1"), std::string::npos) << r.fault_reason;  // R_EFE
  EXPECT_NE(r.fault_reason.find("-> hold"), std::string::npos) << r.fault_reason;
  EXPECT_NE(r.fault_reason.find("at 8.50"), std::string::npos) << r.fault_reason;
  EXPECT_FALSE(r.within_limits);
}

// An encoder that freezes while its joint is still is unobservable until the joint turns; then the
// redundant encoder on the joint's axis parts from it. The elbow's encoder freezes at 8.5 s; the
// elbow first moves at the third posture (about 31.5 s): encoder_disagrees (hold) within the 2 deg
// and 3 cycles. Without the redundant encoder the same run went on blind to 46 s, the elbow drifting
// 50 deg from what its encoder said, until a wire's tension floor latched.
TEST(E3, AnEncoderFrozenAtRestIsCaughtByTheRedundantEncoderWhenTheJointFirstTurns) {
  ArmScenario s = test_support::shipped_right_arm();
  s.postures_stop_s = 40.0;
  s.faults = {sim::parse_fault_spec("encoder_frozen@8.5:R_EFE", arm_joint_names(s), postures_duration_s(s))};
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.faults, 1u) << r.fault_reason;
  EXPECT_TRUE(r.fault_flags & safety::kFaultEncoderDisagrees) << r.fault_reason;
  EXPECT_EQ(r.fault_reason.find("encoder_disagrees joint 1"), 0u) << r.fault_reason;  // the first fault
  EXPECT_NE(r.fault_reason.find("-> hold"), std::string::npos) << r.fault_reason;
  const double at_s = std::stod(r.fault_reason.substr(r.fault_reason.find(" at ") + 4));
  EXPECT_GT(at_s, 31.0) << r.fault_reason;  // not before the elbow moves
  EXPECT_LT(at_s, 32.0) << r.fault_reason;
  // The broken supervisor: without the joint-side encoder nothing is seen in the same 40 s.
  ArmScenario blind = s;
  blind.plant.joint_encoder_counts_per_rev = 0.0;
  EXPECT_EQ(run_postures(blind, nullptr).fault_flags & safety::kFaultEncoderDisagrees, 0u);
}

// A right-arm scenario's optional faults: list is E3's: read against the arm's joints and E3's script
// length, put into E3's plant by postures_plant_params, not into the plant E4 and E6 start from.
TEST(RightArmScenario, FaultsListIsE3sAndNamesTheArmsJoints) {
  const testing::EditedConfig config("right_arm.yaml", "arm_faults");
  auto read_with = [&](const std::string& faults) {
    return read_arm_scenario(config::Document::load_file(config.write(config.shipped() + "\nfaults:\n" + faults)));
  };
  const ArmScenario s = read_with("  - {kind: wire_break, time_s: 9.0, joint: R_EFE, muscle: antagonist}\n"
                                  "  - {kind: encoder_jump, time_s: 12.0, joint: R_SFE, value: 5.0}\n");
  ASSERT_EQ(s.faults.size(), 2u);
  EXPECT_EQ(s.faults[0].kind, sim::FaultKind::kWireBreak);
  EXPECT_EQ(s.faults[0].joint, 1);
  EXPECT_EQ(s.faults[0].muscle, 1);
  EXPECT_EQ(s.faults[1].joint, 0);
  EXPECT_DOUBLE_EQ(s.faults[1].value, 5.0);
  EXPECT_EQ(postures_plant_params(s).faults.size(), 2u);
  EXPECT_TRUE(s.plant.faults.empty());
  try {
    read_with("  - {kind: motor_fault, time_s: 9.0, joint: elbow}\n");
    ADD_FAILURE() << "a joint the arm does not have was accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("R_EFE"), std::string::npos) << e.what();
  }
}

// E4's and E6's joints and postures come from the joint list: goniometer.joints and bandwidth.joint
// name io joints, goniometer.angles_deg and bandwidth.angles_deg are postures as E3's (by arm joint for
// every side, or by io joint). The right arm holds its shoulder and drives its elbow; the upper body
// drives both elbows with both shoulders held, and sweeps the left elbow.
TEST(ArmScenario, E4AndE6ReadTheirJointsAndPosturesByName) {
  const ArmScenario right = test_support::shipped_right_arm();
  EXPECT_EQ(right.goniometer.joints, std::vector<int>{1});
  ASSERT_EQ(right.goniometer.held_rad.size(), 3u);
  EXPECT_NEAR(right.goniometer.held_rad[0], models::deg_to_rad(-90), 1e-12);
  EXPECT_TRUE(std::isnan(right.goniometer.held_rad[1]));
  EXPECT_TRUE(std::isnan(right.goniometer.held_rad[2]));  // the wrist: where the plant starts it
  EXPECT_EQ(right.bandwidth.joint, 1);
  EXPECT_NEAR(right.bandwidth.locked_rad[0], models::deg_to_rad(-90), 1e-12);
  EXPECT_NEAR(right.bandwidth.locked_rad[1], models::deg_to_rad(90), 1e-12);
  EXPECT_TRUE(std::isnan(right.bandwidth.locked_rad[2]));
  const ArmScenario upper = read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  EXPECT_EQ(upper.goniometer.joints, (std::vector<int>{2, 6}));  // R_EFE, L_EFE
  for (const std::size_t shoulder : {0u, 4u}) EXPECT_NEAR(upper.goniometer.held_rad[shoulder], 0.0, 1e-12);      // SAA
  for (const std::size_t shoulder : {1u, 5u}) EXPECT_NEAR(upper.goniometer.held_rad[shoulder], models::deg_to_rad(-90), 1e-12);  // SFE
  EXPECT_EQ(upper.bandwidth.joint, 6);  // L_EFE
  EXPECT_NEAR(upper.bandwidth.locked_rad[2], models::deg_to_rad(90), 1e-12);
}

// A goniometer or bandwidth section naming a joint the arm cannot drive by torque is refused at load
// time with the file, the field and expected vs found: a passive joint (R_WR) or one the arm does not
// have, the wrist held at a constant pressure, a held posture naming a driven joint, a bench posture
// without the swept joint.
/// The error reading `config` with `from` replaced by `to` gives ("" if it reads).
std::string read_error_after(const testing::EditedConfig& config, const std::string& from, const std::string& to) {
  bool found = false;
  const std::filesystem::path path = config.write_replacing(from, to, &found);
  EXPECT_TRUE(found) << from;
  try {
    read_arm_scenario(config::Document::load_file(path));
  } catch (const config::Error& e) {
    return std::string(e.what());
  }
  return std::string();
}

// goniometer.tremor: a filter that could not work is refused by the key that breaks it, with the
// file and line (a high-pass above the band it searches would take the tremor out of the fit's input).
TEST(ArmScenario, RefusesATremorFilterThatCannotWork) {
  const testing::EditedConfig config("right_arm.yaml", "arm_tremor");
  auto error_after = [&](const std::string& from, const std::string& to) { return read_error_after(config, from, to); };
  using ::testing::HasSubstr;
  EXPECT_THAT(error_after("highpass_Hz: 3.5", "highpass_Hz: 5.0"), HasSubstr("goniometer.tremor.highpass_Hz"));
  EXPECT_THAT(error_after("highpass_Hz: 3.5", "highpass_Hz: 5.0"), HasSubstr("right_arm.yaml:"));
  EXPECT_THAT(error_after("gate_full_deg: 0.7", "gate_full_deg: 0.2"), HasSubstr("goniometer.tremor.gate_full_deg"));
  EXPECT_THAT(error_after("initial_frequency_Hz: 7.0", "initial_frequency_Hz: 13.0"), HasSubstr("goniometer.tremor.min_frequency_Hz"));
  EXPECT_THAT(error_after("tracking_rate: 0.1", "tracking_rate: 0.9"), HasSubstr("goniometer.tremor.tracking_rate"));
}

TEST(ArmScenario, RefusesE4AndE6JointsTheArmCannotDrive) {
  const testing::EditedConfig config("right_arm.yaml", "arm_e4e6");
  auto error_after = [&](const std::string& from, const std::string& to) { return read_error_after(config, from, to); };
  using ::testing::HasSubstr;
  const std::string passive = error_after("joints: [R_EFE]", "joints: [R_WR]");
  int line = 0;  // the line of the list item in the shipped file (1-based)
  {
    std::ifstream shipped(PEHA_SOURCE_DIR "/configs/right_arm.yaml");
    std::string text;
    for (int n = 1; std::getline(shipped, text); ++n) {
      if (text.find("joints: [R_EFE]") != std::string::npos) {
        line = n;
        break;
      }
    }
  }
  ASSERT_GT(line, 0);
  EXPECT_THAT(passive, HasSubstr("right_arm.yaml:" + std::to_string(line) + ":"));  // file and line of the list item
  EXPECT_THAT(passive, HasSubstr("goniometer.joints[0]: expected one of {R_SFE, R_EFE, R_WFE}, found 'R_WR'"));
  EXPECT_THAT(error_after("joints: [R_EFE]", "joints: [L_EFE]"), HasSubstr("goniometer.joints[0]: expected one of {R_SFE, R_EFE, R_WFE}, found 'L_EFE'"));
  EXPECT_THAT(error_after("joints: [R_EFE]", "joints: [R_EFE, R_WFE]"),
              HasSubstr("goniometer.joints: expected a joint with a peha or pam_pair actuator, found R_WFE (actuator constant_pressure"));
  EXPECT_THAT(error_after("angles_deg: {SFE: -90.0}    #", "angles_deg: {SFE: -90.0, EFE: 30.0}    #"),
              HasSubstr("goniometer.angles_deg: expected the posture of the joints the goniometers do not drive, found R_EFE"));
  EXPECT_THAT(error_after("joint: R_EFE ", "joint: R_WR "), HasSubstr("bandwidth.joint: expected one of {R_SFE, R_EFE, R_WFE}, found 'R_WR'"));
  EXPECT_THAT(error_after("joint: R_EFE ", "joint: R_WFE "),
              HasSubstr("bandwidth.joint: expected a joint with a peha or pam_pair actuator, found R_WFE"));
  EXPECT_THAT(error_after("angles_deg: {SFE: -90.0, EFE: 90.0}   #", "angles_deg: {SFE: -90.0}   #"),
              HasSubstr("bandwidth.angles_deg: expected the swept joint R_EFE among the locked joints"));
  EXPECT_THAT(error_after("angles_deg: {SFE: -90.0, EFE: 90.0}   #", "angles_deg: {SFE: -90.0, EFE: 90.0, WR: 0.0}   #"),
              HasSubstr("bandwidth.angles_deg.WR: unknown key"));
  EXPECT_EQ(error_after("joint: R_EFE ", "joint: R_SFE "), "");  // the shoulder has a motor and muscles: a bench joint too
}

}  // namespace
}  // namespace peha::experiments
