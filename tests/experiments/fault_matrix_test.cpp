// The fault matrix (peha faults, docs/safety.md) on small subsets: E1's nominal row, a stuck load
// cell and a NaN from the controller while holding; E3's on the right arm's elbow. The rows report what the monitor did, measured
// from the log: the flag, the cycles to it, and the plant's figures after the fault.
#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

namespace peha::experiments {
namespace {

TEST(FaultMatrix, HoldingRowsNameTheFlagTheCyclesAndThePlantsFigures) {
  const E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.kinds = {sim::FaultKind::kLoadcellStuck, sim::FaultKind::kControllerNan};
  o.moments = {"holding"};
  o.after_fault_s = 2.0;
  const std::vector<FaultRow> rows = run_fault_matrix(s, o);
  ASSERT_EQ(rows.size(), 3u);
  const FaultRow& nominal = rows[0];
  EXPECT_EQ(nominal.fault, "none");
  EXPECT_FALSE(nominal.detected) << nominal.flag;  // no false alarm while holding (6 s)
  EXPECT_TRUE(nominal.log_complete);
  const FaultRow& stuck = rows[1];
  EXPECT_EQ(stuck.fault, "loadcell_stuck");
  EXPECT_TRUE(stuck.detected);
  EXPECT_EQ(stuck.flag, "loadcell_stuck");
  EXPECT_GE(stuck.detection_cycles, 0.0);
  EXPECT_EQ(stuck.prompt_cycles, s.limits.monitor.loadcell_stuck_cycles);  // its own window (8): fewer equal readings happen by chance
  EXPECT_LE(stuck.detection_cycles, stuck.prompt_cycles);
  EXPECT_FALSE(stuck.passed);  // a faulted run never passes
  EXPECT_LE(stuck.peak_force_N, 2000.0);
  const FaultRow& nan = rows[2];
  EXPECT_EQ(nan.flag, "nonfinite_command");
  EXPECT_LE(nan.detection_cycles, 1.0);
  EXPECT_EQ(nan.limits_exceeded, 0);
  EXPECT_TRUE(nan.log_complete);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_fault_matrix_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_fault_matrix(dir, rows, "e1_one_dof.yaml");
  std::ifstream md(dir / "faults.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_NE(text.str().find("| loadcell_stuck | joint.agonist | holding | loadcell_stuck |"), std::string::npos) << text.str();
  std::filesystem::remove_all(dir);
}

// Issue 29 item 9: recovery after an outage is a row of the matrix. E1 5 kg, holding: 2.5 s of lost
// state packets (the host holds the last command, the board follows it) and a board off for 2.5 s
// (it vents the link onto its stop, then boots disarmed); the operator recovers 0.5 s after the
// samples return. Both are seen by the lifecycle's watchdog (20 ms: 21 cycles), re-armed 3.02 s
// after the fault, and judged from the first sample after the outage: within 90 deg/s and never
// further out of the range than where the outage left the link (measured: 26.4 and 66.6 deg/s).
TEST(FaultMatrix, AnOutageRowRecoversWithoutLaunchingTheJoint) {
  const E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.case_name = "payload_5.0kg";
  o.kinds = {sim::FaultKind::kStateLoss, sim::FaultKind::kBoardReboot};
  o.moments = {"holding"};
  o.after_fault_s = 3.0;
  const std::vector<FaultRow> rows = run_fault_matrix(s, o);
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const FaultRow& r = rows[i];
    SCOPED_TRACE(r.fault);
    EXPECT_TRUE(r.detected);
    EXPECT_EQ(r.flag, "backend silent");
    EXPECT_EQ(r.safe_state, "hold");  // the board may still hear the host: held armed, not vented
    EXPECT_LE(r.detection_cycles, r.prompt_cycles);
    EXPECT_EQ(r.prompt_cycles, 21);  // host_watchdog_ms 20 at 1 kHz
    EXPECT_NEAR(r.recovered_after_s, 2.5 + o.recover_delay_s, 0.05);
    EXPECT_LE(r.peak_speed_degps, 90.0);
    EXPECT_LE(r.peak_force_N, 2000.0);
    EXPECT_EQ(r.limits_exceeded, 0);
    EXPECT_TRUE(r.log_complete);  // a row per sample: none in the outage
  }
  EXPECT_GT(rows[1].min_tension_N, 20.0);  // the lost uplink held the link: its wires stay taut
  // The same loss during the start-up's tare and vent (issue 29 item 2): re-armed, the start pin
  // stays in until the recovery ramp has refilled the muscles (FaultMonitor::controller_in_command)
  // and the controller restarts from the measured pressures. Measured 25.8 deg/s, 878 N; before: the
  // pin pulled at 30 % of the ramp, the link fell at 118 deg/s and the catch pulled 1226 N (at the
  // vent 76.5 deg/s; the pin alone left in the ramp: 89 deg/s).
  o.kinds = {sim::FaultKind::kStateLoss};
  o.moments = {"startup_vent", "tare"};
  const std::vector<FaultRow> startup = run_fault_matrix(s, o);
  ASSERT_EQ(startup.size(), 3u);
  for (std::size_t i = 1; i < startup.size(); ++i) {
    SCOPED_TRACE(startup[i].moment);
    EXPECT_FALSE(std::isnan(startup[i].recovered_after_s));
    EXPECT_LE(startup[i].peak_speed_degps, 40.0);
    EXPECT_LE(startup[i].peak_force_N, 950.0);
    EXPECT_EQ(startup[i].limits_exceeded, 0);
    EXPECT_GT(startup[i].min_tension_N, 20.0);  // judged from the ramp's end: refilled
  }
}

// Issue 29: two faults at once are rows of the matrix. A dead pressure sensor behind a stuck-open
// valve (E1 5 kg, holding): the sensor's failure parts the cell from the model at once
// (loadcell_disagrees, 3 cycles), the over-ceiling window vents - and the stuck valve refills the
// muscle past its ceiling anyway (2695 N measured): a row physics forbids, named with its reason. A
// pair runs only when both its kinds are wanted.
TEST(FaultMatrix, ADoubleFaultIsARowAndPhysicsForbidsIsNamed) {
  const E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.case_name = "payload_5.0kg";
  o.kinds = {sim::FaultKind::kPressureSensorFail, sim::FaultKind::kValveStuckOpen};
  o.moments = {"holding"};
  o.after_fault_s = 2.0;
  const std::vector<FaultRow> rows = run_fault_matrix(s, o);
  ASSERT_EQ(rows.size(), 4u);  // none, the two singles, the pair
  const FaultRow& pair = rows[3];
  EXPECT_EQ(pair.fault, "pressure_sensor_fail+valve_stuck_open");
  EXPECT_TRUE(pair.detected);
  EXPECT_LE(pair.detection_cycles, 5.0);
  EXPECT_GT(pair.peak_force_N, 2000.0);
  EXPECT_GE(pair.limits_exceeded, 1);
  EXPECT_NE(pair.physics_forbids.find("stuck valve"), std::string::npos) << pair.physics_forbids;
  o.kinds = {sim::FaultKind::kPressureSensorFail};
  EXPECT_EQ(run_fault_matrix(s, o).size(), 2u);  // the pair needs both kinds
}

// A carrying valve stuck closed during the push (E1 5 kg) keeps the air the finger's help needed:
// pressure_low, descend. The governor bleeds its command below that air - which a pressure_high
// judged as a valve filling by itself and vented: the dump valve emptied the muscle and the link
// fell at 222 deg/s out of its range. Not judged on a muscle that does not follow, the trapped air
// holds the link (24.5 deg/s at most, the finger's own move) and no limit is exceeded.
TEST(FaultMatrix, AStuckClosedValveUnderDescendIsNotVentedAsAFillingOne) {
  const E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.case_name = "payload_5.0kg";
  o.kinds = {sim::FaultKind::kValveStuckClosed};
  o.moments = {"push"};
  const FaultRow row = run_fault_matrix(s, o).at(1);
  EXPECT_EQ(row.flag, "pressure_low");
  EXPECT_EQ(row.safe_state, "descend");
  EXPECT_EQ(row.limits_exceeded, 0);
  EXPECT_LE(row.peak_speed_degps, 30.0);
}

// Issue 29: a load cell whose zero creeps 10 N/s from `holding` (E1 2.5 kg) is too slow for the step
// check and inside the disagreement tolerance; the force trim follows it, the real force leaves the
// wanted one, and left alone the link leaves its range 14 s later. The drift check sums the
// disagreement's change while the link is still: caught inside the range (descend), no limit
// exceeded; with the check off the same row leaves its range.
TEST(FaultMatrix, ADriftingLoadCellIsCaughtBeforeTheLinkLeavesItsRange) {
  E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.case_name = "payload_2.5kg";
  o.kinds = {sim::FaultKind::kLoadcellDrift};
  o.moments = {"holding"};
  o.after_fault_s = 1.0;  // the slow fault's row runs slow_after_fault_s (20 s) all the same
  const FaultRow drift = run_fault_matrix(s, o).at(1);
  EXPECT_EQ(drift.flag, "loadcell_drift");
  EXPECT_EQ(drift.safe_state, "descend");
  EXPECT_LE(drift.detection_cycles, 10000.0);  // 10 s: 100 N of drift (6.9 s measured)
  EXPECT_EQ(drift.limits_exceeded, 0);
  EXPECT_LT(drift.peak_speed_degps, 90.0);  // governed (the finger's release at 18 s is caught at 60); a fall trips 90
  s.limits.test_overrides.unchecked = safety::kFaultLoadcellDrift;
  const FaultRow unchecked = run_fault_matrix(s, o).at(1);
  EXPECT_NE(unchecked.flag, "loadcell_drift");
  EXPECT_GE(unchecked.limits_exceeded, 1);  // the range
}

// The E3 rows on the right arm, a subset: the nominal run, a stuck load cell on the elbow's agonist and
// the supply falling to 0, each at `holding` (1 s after the first posture's release: 8.5 s) and
// `moving` (the middle of the move to the second posture: 18.75 s). Measured (seed 1): the stuck cell
// latches loadcell_stuck 19 cycles after the fault (the arm's loadcell_stuck_cycles is 20: its
// shoulder cell repeats codes in nominal runs) and the arm descends without exceeding a limit; the
// supply loss is seen by the supply sensor in 3 cycles, at rest and moving, and held.
TEST(FaultMatrix, E3RowsOnTheElbowDetectTheStuckCellAndHoldAfterASupplyLoss) {
  const ArmScenario s = peha::test_support::shipped_right_arm();
  const std::vector<FaultMoment> moments = e3_fault_moments(s);
  ASSERT_EQ(moments.size(), 4u);
  EXPECT_NEAR(moments[0].time_s, 8.5, 1e-9);   // first posture released at 7.5 s
  EXPECT_NEAR(moments[1].time_s, 18.75, 1e-9); // second move from 17.5 s, 2.5 s long
  EXPECT_EQ(moments[2].name, "elbow_moving");  // the middle of the move into elbow_90
  EXPECT_EQ(moments[3].name, "elbow_flexed");  // elbow_90, the first posture with the elbow flexed, released at 48 s
  EXPECT_NEAR(moments[3].time_s, 49.0, 1e-9);
  FaultMatrixOptions o;
  o.kinds = {sim::FaultKind::kLoadcellStuck, sim::FaultKind::kSupplyZero};
  o.moments = {"holding", "moving"};
  const std::vector<FaultRow> rows = run_fault_matrix(s, o);
  ASSERT_EQ(rows.size(), 5u);
  for (const FaultRow& r : rows) {
    EXPECT_EQ(r.experiment, "E3");
    EXPECT_TRUE(r.log_complete) << r.fault << " " << r.moment;
    EXPECT_LE(r.peak_force_N, 2000.0) << r.fault << " " << r.moment;
  }
  const FaultRow& nominal = rows[0];
  EXPECT_EQ(nominal.fault, "none");
  EXPECT_FALSE(nominal.detected) << nominal.flag;  // no false alarm to 23.75 s
  EXPECT_EQ(nominal.limits_exceeded, 0);

  const FaultRow& stuck = rows[1];
  EXPECT_EQ(stuck.fault, "loadcell_stuck");
  EXPECT_EQ(stuck.target, "R_EFE.agonist");
  EXPECT_EQ(stuck.moment, "holding");
  EXPECT_EQ(stuck.flag, "loadcell_stuck");
  EXPECT_GE(stuck.detection_cycles, 0.0);
  EXPECT_LE(stuck.detection_cycles, s.limits.monitor.loadcell_stuck_cycles);
  EXPECT_EQ(stuck.safe_state, "descend");
  EXPECT_EQ(stuck.limits_exceeded, 0);

  // The supply sensor on the valve manifold sees the loss at once, also at rest (before it, the loss
  // was unobservable at rest and seen 293 cycles into the move as pressure_low); with no air to brake
  // a descent with, the arm holds.
  const FaultRow& supply_holding = rows[2];
  EXPECT_EQ(supply_holding.fault, "supply_zero");
  EXPECT_EQ(supply_holding.target, "arm");
  EXPECT_EQ(supply_holding.flag, "supply_loss");
  EXPECT_LE(supply_holding.detection_cycles, 3.0);
  EXPECT_EQ(supply_holding.safe_state, "hold");
  EXPECT_LT(supply_holding.peak_speed_degps, 5.0);
  EXPECT_EQ(supply_holding.limits_exceeded, 0);

  const FaultRow& supply_moving = rows[4];
  EXPECT_EQ(supply_moving.fault, "supply_zero");
  EXPECT_EQ(supply_moving.moment, "moving");
  EXPECT_EQ(supply_moving.flag, "supply_loss");
  EXPECT_LE(supply_moving.detection_cycles, 3.0);
  EXPECT_EQ(supply_moving.safe_state, "hold");
  EXPECT_EQ(supply_moving.limits_exceeded, 0);
  EXPECT_TRUE(supply_moving.physics_forbids.empty());

  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_fault_matrix_e3_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_fault_matrix(dir, rows, "right_arm.yaml");
  std::stringstream md, csv;
  md << std::ifstream(dir / "faults.md").rdbuf();
  csv << std::ifstream(dir / "faults.csv").rdbuf();
  EXPECT_NE(md.str().find("# Fault matrix: E3"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| loadcell_stuck | R_EFE.agonist | holding | loadcell_stuck |"), std::string::npos) << md.str();
  EXPECT_EQ(csv.str().rfind("experiment,fault,target,moment,", 0), 0u) << csv.str();
  EXPECT_NE(csv.str().find("\nE3,supply_zero,arm,moving,"), std::string::npos) << csv.str();
  std::filesystem::remove_all(dir);
}

/// The shipped right-arm scenario.
ArmScenario shipped_arm() { return peha::test_support::shipped_right_arm(); }

/// E3's fault matrix on `s` with one fault kind at one moment: the faulted row (after the nominal one).
FaultRow e3_row(ArmScenario s, sim::FaultKind kind, const char* moment) {
  FaultMatrixOptions o;
  o.kinds = {kind};
  o.moments = {moment};
  const std::vector<FaultRow> rows = run_fault_matrix(std::move(s), o);
  EXPECT_EQ(rows.size(), 2u);
  return rows.back();
}

// The descend safe state while the operator carries the arm down (a stuck elbow cell at `moving`):
// the governor takes the operator's move for a fall and brakes the shoulder. It governs only the
// actuated joints - the constant-pressure wrist keeps its held pressures - and its force rises at
// most descent_force_slew_N_per_s (5000 N/s on the arm), so nothing whips: peak speed 77 deg/s (the
// wrist; the operator moves the shoulder at 65), shoulder force 766 N (98 deg/s and 822 N with the
// shoulder's cells trimming its force, descent_trim_rate_per_s 5). Without the slew limit the braking
// step whips the wrist to 180 deg/s.
TEST(FaultMatrix, E3DescendBrakesTheOperatorsMoveWithoutWhippingTheWrist) {
  const ArmScenario shipped = shipped_arm();
  auto moving_row = [](ArmScenario s) { return e3_row(std::move(s), sim::FaultKind::kLoadcellStuck, "moving"); };
  const FaultRow r = moving_row(shipped);
  EXPECT_EQ(r.safe_state, "descend");
  EXPECT_EQ(r.limits_exceeded, 0);
  EXPECT_LE(r.peak_speed_degps, 110.0);  // measured 77 (the wrist)
  EXPECT_LE(r.peak_force_N, 900.0);      // measured 766

  ArmScenario no_slew = shipped;
  no_slew.limits.monitor.descent_force_slew_N_per_s = 1e6;
  EXPECT_GT(moving_row(no_slew).peak_speed_degps, 150.0);  // measured 180 (the wrist)
}

// Issue 29: a descend that lasts through the operator's next move hands the arm to the operator and
// back. An elbow cell creeping 10 N/s from 1 s after the release of elbow_90; the operator then lifts
// the arm into raised_flexed and holds it for a second. The governor used to bleed the shoulder while
// the hand held it, and its pressure model read 268 N where the shoulder's agonist made 1 N: let go,
// the arm fell onto a bled force and the wrist whipped to 904 deg/s; bled at a fifth of the rate while
// the lifted arm is held, 851. Trimming the shoulder's force by its own (healthy) cells as well
// (descent_trim_rate_per_s 5, off by default: it hurt the upper body's matrix) brings it to 473.
// Before either, the creeping cell lets the elbow fall from 88 deg onto its stop (327 deg/s, 2.2 deg
// into it) before loadcell_drift can tell the drift from the model's error; the range judged ahead
// (range_lead_s, range_brake_radps2) catches that fall inside the range: no limit exceeded.
TEST(FaultMatrix, E3AnArmHandedBackUnderDescendIsNotDroppedOntoABledForce) {
  auto row = [](ArmScenario s) { return e3_row(std::move(s), sim::FaultKind::kLoadcellDrift, "elbow_flexed"); };
  const ArmScenario shipped = shipped_arm();
  ArmScenario unled = shipped;  // the range on the angle alone: the drift's own check latches, after the fall
  unled.limits.monitor.range_lead_s = 0.0;
  unled.limits.monitor.range_brake_radps2 = std::numeric_limits<double>::infinity();
  const FaultRow r = row(unled);
  EXPECT_EQ(r.flag, "loadcell_drift");
  EXPECT_EQ(r.safe_state, "descend");
  EXPECT_EQ(r.limits_exceeded, 1);  // the elbow 2.2 deg into its stop
  ArmScenario trimmed = unled;
  trimmed.limits.monitor.descent_trim_rate_per_s = 5.0;
  EXPECT_LT(row(trimmed).peak_speed_degps, 500.0);  // measured 473 (the wrist)
  ArmScenario old = unled;
  old.limits.monitor.descent_lifted_bleed_fraction = 1.0;
  EXPECT_GT(row(old).peak_speed_degps, r.peak_speed_degps + 30.0);  // measured 904 against 851

  const FaultRow led = row(shipped);
  EXPECT_EQ(led.flag, "joint_range");
  EXPECT_EQ(led.limits_exceeded, 0);
}

// The descend governor while the operator flexes the elbow (a stuck load cell in the middle of the
// move into elbow_90): the carrying flexor keeps its force while the joint is lifted, so its wire
// stays taut (the lowest wire of the arm is the wrist's, 11.2 N measured) and the wrist swings at
// 89 deg/s. The old governor bled the flexor while the operator lifted: its wire fell to 1.1 N and
// the wrist whipped to 288 deg/s.
TEST(FaultMatrix, E3DescendKeepsTheFlexorTautWhileTheOperatorFlexesTheElbow) {
  auto row = [](ArmScenario s) { return e3_row(std::move(s), sim::FaultKind::kLoadcellStuck, "elbow_moving"); };
  const ArmScenario shipped = shipped_arm();
  const FaultRow r = row(shipped);
  EXPECT_EQ(r.safe_state, "descend");
  EXPECT_EQ(r.limits_exceeded, 0);
  EXPECT_GE(r.min_tension_N, 8.0);
  EXPECT_LE(r.peak_speed_degps, 120.0);
  ArmScenario old = shipped;
  old.limits.test_overrides.governor_bleeds_while_lifted = true;
  const FaultRow o = row(old);
  EXPECT_LT(o.min_tension_N, 3.0);
  EXPECT_EQ(o.min_tension_joint, "R_EFE");
}

// Issue 29 item 2 on the arm: the state packets lost while the operator moves the arm (`moving`).
// The host held the last command; between the samples' return and the recovery the controller's trims
// integrated against it (and over the outage's 2.5 s as one step): re-armed, the shoulder's antagonist
// ramped toward 0.8 MPa, the arm was driven onto its stop at 115 deg/s and the wrist swung at 623
// deg/s, the elbow's flexor wire at 0.7 N. Restarted from the measured pressures (ArmController::resume)
// the fastest joint is the shoulder pulled back by the held pressures as the samples return (111 deg/s,
// the operator gone) and every wire stays taut (19.3 N, the wrist's).
TEST(FaultMatrix, E3StateLossWhileMovingReArmsFromTheMeasuredPressures) {
  const FaultRow r = e3_row(shipped_arm(), sim::FaultKind::kStateLoss, "moving");
  EXPECT_EQ(r.flag, "backend silent");
  EXPECT_FALSE(std::isnan(r.recovered_after_s));
  EXPECT_EQ(r.limits_exceeded, 0);
  EXPECT_LE(r.peak_speed_degps, 150.0);
  EXPECT_GT(r.min_tension_N, 10.0);
}

// A board that reboots while the operator flexes the elbow is off for 2.5 s: its outputs vent, the
// arm falls onto its stops while nothing is armed, and the first samples back show the tail of that
// fall (the wrist at 821 deg/s, before the re-arm at 3.0 s). The limits exceeded are counted and the
// row names why physics forbids them; from the re-arm on every joint stays within them (45 deg/s).
// A lost uplink at the same moment keeps the outputs armed: no such reason, and none needed.
TEST(FaultMatrix, E3BoardRebootFallWhileDisarmedIsNamedPhysicsAndTheReArmIsClean) {
  const FaultRow reboot = e3_row(shipped_arm(), sim::FaultKind::kBoardReboot, "elbow_moving");
  EXPECT_GT(reboot.peak_speed_degps, 500.0);
  EXPECT_GE(reboot.limits_exceeded, 1);
  EXPECT_NE(reboot.physics_forbids.find("from the re-arm on every joint within the limits"), std::string::npos) << reboot.physics_forbids;
  const FaultRow loss = e3_row(shipped_arm(), sim::FaultKind::kStateLoss, "elbow_moving");
  EXPECT_EQ(loss.limits_exceeded, 0);
  EXPECT_TRUE(loss.physics_forbids.empty());
}

// A moment the experiment does not have is an error, not an empty matrix.
TEST(FaultMatrix, AMomentTheExperimentLacksIsRefused) {
  const E1Scenario s = peha::test_support::shipped_e1();
  FaultMatrixOptions o;
  o.moments = {"moving"};
  EXPECT_THROW(run_fault_matrix(s, o), std::invalid_argument);
}

}  // namespace
}  // namespace peha::experiments
