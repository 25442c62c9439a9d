// The right arm's plant-only knobs: a mass in the hand the controller is not told, and injected faults.
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/arm_plant.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace peha::sim {
namespace {

/// The shipped right arm's plant, arm held out horizontally (shoulder and elbow at 0), the
/// backend inactive (valves vented, motors off): where the shoulder is 0.3 s later.
double shoulder_after_fall_rad(double unknown_hand_payload_kg) {
  ArmPlantParams p =
      peha::test_support::shipped_right_arm().plant;
  p.initial_q_rad.assign(p.initial_q_rad.size(), 0.0);
  p.settle_s = 0.0;  // released held out at t = 0, not settled hanging
  p.unknown_hand_payload_kg = unknown_hand_payload_kg;
  ArmBackend arm(p);
  io::Command vented;
  vented.joint_count = static_cast<int>(p.actuated.size());
  for (int k = 0; k < 300; ++k) arm.write(vented);
  return arm.truth().q_rad[0];
}

// The unknown mass is in the plant's dynamics: the vented arm, released held out, falls differently
// with 2 kg more in the hand - more slowly at the shoulder (-1.17 vs -1.30 rad after 0.3 s, seed 1):
// a mass at the tip adds relatively more inertia (m L^2) than gravity torque (m g L) compared with
// the arm's own, distributed mass (for a rod alone 1.5 g / L, a tip mass alone g / L). A payload whose
// unknown part makes it negative is rejected at set-up.
TEST(RightArmPlant, UnknownHandPayloadWeighsInTheHand) {
  const double nominal = shoulder_after_fall_rad(0.0);
  const double heavier = shoulder_after_fall_rad(2.0);
  EXPECT_LT(nominal, 0.0);  // the arm falls
  EXPECT_GT(heavier, nominal + models::deg_to_rad(1.0));
  EXPECT_THROW(shoulder_after_fall_rad(-0.5), std::invalid_argument);  // the shipped hand holds 0 kg
}

}  // namespace
}  // namespace peha::sim

namespace peha::sim {
namespace {

// Injected faults on the simulated arm (sim/plant_faults.hpp): each hits the actuated joint it names
// (io order R_SFE, R_EFE, R_WFE) at its time and nothing else, as the one-DOF rig's do; supply faults
// hit every joint (one supply). The arm starts hanging (the shipped E3 start), the backend active, every
// muscle commanded to `pressure_MPa` (motors off).
const ArmPlantParams& shipped_arm() {
  static const ArmPlantParams plant =
      peha::test_support::shipped_right_arm().plant;
  return plant;
}

struct ArmUnderFault {
  ArmPlantParams params;
  std::unique_ptr<ArmBackend> arm;
  io::Command command;
  io::SensorState state;

  explicit ArmUnderFault(std::vector<PlantFault> faults, double pressure_MPa = 0.3) {
    params = shipped_arm();
    params.faults = std::move(faults);
    arm = std::make_unique<ArmBackend>(params);
    arm->activate();
    command.joint_count = static_cast<int>(params.actuated.size());
    for (int a = 0; a < command.joint_count; ++a) {
      command.joints[static_cast<std::size_t>(a)].agonist_pressure_Pa = pressure_MPa * 1e6;
      command.joints[static_cast<std::size_t>(a)].antagonist_pressure_Pa = pressure_MPa * 1e6;
    }
  }
  /// One control cycle: write the command, read the new sample.
  void cycle() {
    arm->write(command);
    arm->read(state);
  }
};

PlantFault fault(FaultKind kind, double time_s, int joint, int muscle = 0, double value = 0) {
  return PlantFault{kind, time_s, joint, muscle, value};
}

// A stuck load cell repeats its reading from the fault on; the cells next to it keep their noise
// (1 N on the DMSP-40s' cells: a live cell never repeats 100 times).
TEST(ArmPlantFaults, AStuckLoadCellRepeatsItsReadingOnItsJointOnly) {
  ArmUnderFault run({fault(FaultKind::kLoadcellStuck, 0.1, 1, 0)});
  std::vector<double> elbow, shoulder;
  for (int k = 0; k < 200; ++k) {
    run.cycle();
    elbow.push_back(run.state.joints[1].agonist_loadcell_N);
    shoulder.push_back(run.state.joints[0].agonist_loadcell_N);
  }
  auto distinct = [](std::vector<double> v, std::size_t from, std::size_t to) {
    std::sort(v.begin() + static_cast<std::ptrdiff_t>(from), v.begin() + static_cast<std::ptrdiff_t>(to));
    return static_cast<std::size_t>(std::unique(v.begin() + static_cast<std::ptrdiff_t>(from), v.begin() + static_cast<std::ptrdiff_t>(to)) -
                                    (v.begin() + static_cast<std::ptrdiff_t>(from)));
  };
  EXPECT_GT(distinct(elbow, 0, 99), 10u);     // live before 0.1 s
  EXPECT_EQ(distinct(elbow, 101, 200), 1u);   // stuck after
  EXPECT_GT(distinct(shoulder, 101, 200), 10u);
}

// The arm's one supply: supply_zero on any joint keeps every muscle of every joint from filling (a
// check valve keeps the air they had); at half supply none fills above half of 0.8 MPa.
TEST(ArmPlantFaults, ASupplyFaultHitsEveryJoint) {
  auto highest_MPa = [](std::vector<PlantFault> faults) {
    ArmUnderFault run(std::move(faults), 0.7);
    for (int k = 0; k < 1500; ++k) run.cycle();
    std::array<double, 6> p{};
    for (std::size_t a = 0; a < 3; ++a) {
      for (std::size_t m = 0; m < 2; ++m) p[2 * a + m] = run.arm->truth().actuators[a].pressure_Pa[m] * 1e-6;
    }
    return p;
  };
  const auto nominal = highest_MPa({});
  const auto zero = highest_MPa({fault(FaultKind::kSupplyZero, 0.0, 2)});  // named on the wrist: hits all three
  const auto half = highest_MPa({fault(FaultKind::kSupplyHalf, 0.0, 0)});
  const double initial_MPa[6] = {0.1, 0.4, 0.08, 0.4, 0.25, 0.25};  // configs/right_arm.yaml plant initial_pressure_MPa
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_GT(nominal[i], 0.65) << i;
    EXPECT_LE(zero[i], initial_MPa[i] + 1e-6) << i;
    EXPECT_LE(half[i], std::max(0.4, initial_MPa[i]) + 1e-6) << i;
  }
}

// An encoder jump offsets its joint's reading by the jump (10 deg, within a count); a frozen encoder
// repeats its reading while the joint moves (the arm swings under 0.3 MPa on every muscle).
TEST(ArmPlantFaults, EncoderFaultsShowInTheirJointsReadingOnly) {
  ArmUnderFault run({fault(FaultKind::kEncoderJump, 0.05, 1, 0, 10.0), fault(FaultKind::kEncoderFrozen, 0.05, 0)});
  for (int k = 0; k < 49; ++k) run.cycle();
  const double count_rad = 2.0 * std::numbers::pi / run.params.encoder_counts_per_rev;
  EXPECT_NEAR(run.state.joints[1].angle_rad, run.arm->truth().q_rad[1], count_rad);  // before the fault
  for (int k = 0; k < 200; ++k) run.cycle();
  const ArmTruth& t = run.arm->truth();
  EXPECT_NEAR(run.state.joints[1].angle_rad - t.q_rad[1], models::deg_to_rad(10.0), count_rad);
  EXPECT_NEAR(run.state.joints[2].angle_rad, t.q_rad[2], count_rad);
  const double frozen = run.state.joints[0].angle_rad;
  for (int k = 0; k < 200; ++k) run.cycle();
  EXPECT_EQ(run.state.joints[0].angle_rad, frozen);
  EXPECT_GT(std::abs(run.arm->truth().q_rad[0] - frozen), models::deg_to_rad(1.0));  // the shoulder did move
}

// A broken wire carries nothing from its time on; the e-stop cuts the outputs through the gate; a
// valve stuck open fills its muscle while the outputs follow, and the dump valve empties it once the
// backend is vented (deactivate(), the supervisor's vent).
TEST(ArmPlantFaults, WireValveAndEstopFaultsActOnTheirTargets) {
  ArmUnderFault broken({fault(FaultKind::kWireBreak, 0.1, 1, 1)});
  for (int k = 0; k < 300; ++k) broken.cycle();
  EXPECT_EQ(broken.arm->truth().actuators[1].pulley_tension_min_N[1], 0.0);
  EXPECT_GT(broken.arm->truth().actuators[1].pulley_tension_min_N[0], 1.0);
  EXPECT_GT(broken.arm->truth().actuators[0].pulley_tension_min_N[1], 1.0);

  ArmUnderFault stop({fault(FaultKind::kEstop, 0.1, 0)});
  for (int k = 0; k < 99; ++k) stop.cycle();
  EXPECT_FALSE(stop.arm->status().estop);
  for (int k = 0; k < 3; ++k) stop.cycle();
  EXPECT_TRUE(stop.arm->status().estop);
  EXPECT_FALSE(stop.arm->status().active);

  ArmUnderFault stuck({fault(FaultKind::kValveStuckOpen, 0.0, 1, 0)}, 0.1);
  for (int k = 0; k < 500; ++k) stuck.cycle();
  const double filled_Pa = stuck.arm->truth().actuators[1].pressure_Pa[0];
  EXPECT_GT(filled_Pa, 0.6e6);                                            // commanded 0.1 MPa
  EXPECT_LT(stuck.arm->truth().actuators[0].pressure_Pa[0], 0.15e6);      // the shoulder's valve follows
  stuck.arm->deactivate();
  for (int k = 0; k < 2500; ++k) stuck.cycle();
  EXPECT_LT(stuck.arm->truth().actuators[1].pressure_Pa[0], 0.05e6);
}

TEST(ArmPlantFaults, AFaultOnAJointTheArmDoesNotHaveIsRefused) {
  ArmPlantParams p = shipped_arm();
  p.faults = {fault(FaultKind::kMotorFault, 1.0, 3)};
  EXPECT_THROW(ArmBackend{p}, std::invalid_argument);
}

}  // namespace
}  // namespace peha::sim
