// A user's own controller through peha::api::Exoskeleton::control, in process on the simulated arm:
// the verdict around it passes a sound controller and fails a wrong one, the callback sees the
// sensors and the model, `finished` ends the run, and what cannot run is refused at set-up.
#include "peha/api/exoskeleton.hpp"
#include "peha/models/units.hpp"

#include "../support/alloc_counter.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>

#include <unistd.h>

namespace peha::api {
namespace {

using ::testing::HasSubstr;

const char* const kArm = PEHA_SOURCE_DIR "/configs/right_arm.yaml";

/// A PD of `stiffness` Nm/rad (damping a tenth) plus the gravity model around where the start-up
/// left the arm, its target moved by `move_deg` from 4 s over `move_s` (0: at once, a jump);
/// `last_error_rad` gets the largest |error| of the torque-controlled joints in the last cycle.
TorqueController pd(double stiffness, const Exoskeleton& exo, double& last_error_rad, double move_deg = 0.0, double move_s = 0.0) {
  auto target = std::make_shared<std::array<double, io::kMaxJoints>>();
  auto started = std::make_shared<bool>(false);
  return [=, &exo, &last_error_rad](const ArmState& s, double) {
    JointTorques tau;
    if (!*started && !s.starting) {
      for (int j = 0; j < s.joint_count; ++j) (*target)[static_cast<std::size_t>(j)] = s.joints[static_cast<std::size_t>(j)].angle_rad;
      *started = true;
    }
    last_error_rad = 0;
    for (std::size_t j = 0; j < static_cast<std::size_t>(s.joint_count); ++j) {
      const JointState& js = s.joints[j];
      tau.tau_Nm[j] = js.gravity_torque_Nm;
      const double progress = move_s > 0 ? std::clamp((s.time_s - 4.0) / move_s, 0.0, 1.0) : (s.time_s >= 4.0 ? 1.0 : 0.0);
      const double goal = (*target)[j] + models::deg_to_rad(move_deg) * 0.5 * (1.0 - std::cos(std::numbers::pi * progress));
      if (*started) tau.tau_Nm[j] += stiffness * (goal - js.angle_rad) - 0.1 * stiffness * js.velocity_radps;
      if (exo.torque_controlled(j)) last_error_rad = std::max(last_error_rad, std::abs(goal - js.angle_rad));
    }
    return tau;
  };
}

TEST(UserController, APdWithGravityHoldsTheArmWithinEveryLimit) {
  Exoskeleton exo(kArm);
  ASSERT_EQ(exo.joint_names(), (std::vector<std::string>{"R_SFE", "R_EFE", "R_WFE"}));
  EXPECT_FALSE(exo.torque_controlled(2));  // the passive wrist: a constant-pressure hold
  double error_rad = 1.0;
  const ControlResult r = exo.control(pd(30.0, exo, error_rad), 4.0);
  EXPECT_TRUE(r.passed) << r.verdict.failures();
  EXPECT_EQ(r.faults, 0u);
  EXPECT_EQ(r.cycles, 4001u);
  EXPECT_LT(models::rad_to_deg(error_rad), 3.0);
}

// A stiff PD (100 Nm/rad) whose target jumps 30 deg jumps the torque faster than the muscles' valves
// follow: the shoulder's wire goes slack (0 N, floor 20 N), and the verdict says so. The same move as
// a 1 s ramp passes. (With the arm started at rest a 10 deg jump at 30 Nm/rad no longer slackens it.)
TEST(UserController, ATargetThatJumpsFailsTheWireTensionFigure) {
  Exoskeleton exo(kArm);
  double error_rad = 0;
  const ControlResult ramped = exo.control(pd(100.0, exo, error_rad, 30.0, 1.0), 6.0);
  EXPECT_TRUE(ramped.passed) << ramped.verdict.failures();
  const ControlResult r = exo.control(pd(100.0, exo, error_rad, 30.0, 0.0), 6.0);
  EXPECT_FALSE(r.passed);
  EXPECT_THAT(r.verdict.failures(), HasSubstr("lowest wire tension"));
}

TEST(UserController, TheCallbackSeesTheSensorsAndTheModelAndCanEndTheRun) {
  Exoskeleton exo(kArm);
  int calls = 0;
  bool saw_startup = false, saw_gravity = false, saw_loadcells = false;
  const ControlResult r = exo.control(
      [&](const ArmState& s, double period_s) {
        ++calls;
        EXPECT_DOUBLE_EQ(period_s, 1e-3);
        saw_startup = saw_startup || s.starting;
        saw_gravity = saw_gravity || std::abs(s.joints[1].gravity_torque_Nm) > 0.01;
        saw_loadcells = saw_loadcells || s.joints[0].agonist_loadcell_N > 10.0;
        JointTorques tau;
        for (int j = 0; j < s.joint_count; ++j) tau.tau_Nm[static_cast<std::size_t>(j)] = s.joints[static_cast<std::size_t>(j)].gravity_torque_Nm;
        tau.finished = s.time_s >= 1.5;
        return tau;
      },
      10.0);
  EXPECT_TRUE(saw_startup && saw_gravity && saw_loadcells);
  EXPECT_NEAR(r.cycles, 1501.0, 2.0);  // ended by the callback, not at 10 s
  EXPECT_EQ(calls, static_cast<int>(r.cycles));
}

// Between two callbacks run peha's step (the allocation, the limits stage, the monitor, the log
// row) and the simulated arm's period: from the first callback after 0.5 s to the last, nothing
// on the heap.
TEST(UserController, ThePerCycleStepAroundTheCallbackAllocatesNothing) {
  Exoskeleton exo(kArm);
  std::size_t first = 0, last = 0;
  (void)exo.control(
      [&](const ArmState& s, double) {
        if (first == 0 && s.time_s >= 0.5) first = testing::allocation_count();
        if (first != 0) last = testing::allocation_count();
        JointTorques tau;
        for (int j = 0; j < s.joint_count; ++j) tau.tau_Nm[static_cast<std::size_t>(j)] = s.joints[static_cast<std::size_t>(j)].gravity_torque_Nm;
        return tau;
      },
      1.0, std::filesystem::temp_directory_path() / ("peha_user_alloc_" + std::to_string(::getpid()) + ".csv"));
  ASSERT_NE(first, 0u);
  EXPECT_EQ(last - first, 0u);
}

TEST(UserController, WhatCannotRunIsRefusedAtSetUp) {
  EXPECT_THROW(Exoskeleton(kArm, "replay:some.csv"), std::invalid_argument);
  EXPECT_THROW(Exoskeleton(kArm, "ethercat://eth0"), std::invalid_argument);
  Exoskeleton exo(kArm);
  EXPECT_THROW((void)exo.control({}, 1.0), std::invalid_argument);
  EXPECT_THROW((void)exo.control([](const ArmState&, double) { return JointTorques{}; }, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace peha::api
