// The right arm's plant-only knob: a mass in the hand the controller is not told.
#include "peha/experiments/right_arm/arm_scenario.hpp"
#include "peha/sim/right_arm.hpp"

#include <gtest/gtest.h>

#include <numbers>
#include <stdexcept>

namespace peha::sim {
namespace {

/// The shipped right arm's plant, arm held out horizontally (shoulder and elbow at 0), the
/// backend inactive (valves vented, motors off): where the shoulder is 0.3 s later.
double shoulder_after_fall_rad(double unknown_hand_payload_kg) {
  RightArmPlantParams p =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml")).plant;
  p.initial_q_rad.assign(p.initial_q_rad.size(), 0.0);
  p.unknown_hand_payload_kg = unknown_hand_payload_kg;
  RightArmBackend arm(p);
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
  EXPECT_GT(heavier, nominal + 1.0 * std::numbers::pi / 180.0);
  EXPECT_THROW(shoulder_after_fall_rad(-0.5), std::invalid_argument);  // the shipped hand holds 0 kg
}

}  // namespace
}  // namespace peha::sim
