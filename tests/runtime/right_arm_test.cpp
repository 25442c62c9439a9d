#include "peha/runtime/right_arm.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace peha::runtime {
namespace {

ArmScenario shipped() { return read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml")); }

// E3 on the simulated right arm (the paper's claim): released in each posture, including (0, 0) where
// the shoulder carries the most, the arm stays - under 0.5 deg in the 10 s after release at both
// joints, with feed-forward J^T G only. Every safety figure holds throughout.
TEST(E3, ArmStaysInEveryPostureWhereTheOperatorLeavesIt) {
  const ArmScenario s = shipped();
  const PosturesResult r = run_postures(s, nullptr);
  ASSERT_EQ(r.postures.size(), s.postures.size());
  EXPECT_TRUE(r.within_limits);
  EXPECT_LE(r.peak_muscle_force_N, 2000.0);
  EXPECT_GT(r.min_wire_tension_N, 0.0);
  for (const PostureResult& p : r.postures) {
    EXPECT_LT(p.max_excursion_deg[0], 0.5) << p.name;
    EXPECT_LT(p.max_excursion_deg[1], 0.5) << p.name;
    // The operator really moved the arm there (within the reach of their 30 Nm hands).
    EXPECT_NEAR(p.released_deg[0], p.target_deg[0], 5.0) << p.name;
    EXPECT_NEAR(p.released_deg[1], p.target_deg[1], 5.0) << p.name;
  }
}

// The arm's control step (J^T G + three allocations + limits) allocates nothing.
TEST(ArmController, StepAllocatesNothing) {
  const ArmScenario s = shipped();
  sim::RightArmBackend plant(s.plant);
  control::ArmController controller(s.controller);
  safety::LimitsData limits;
  io::SensorState state;
  io::Command command;
  std::size_t n = 0;
  for (int k = 0; k < 2000; ++k) {
    plant.read(state);
    n += testing::allocations_during([&] {
      controller.update(state, command);
      safety::apply_limits(s.limits, limits, state, command);
    });
    plant.write(command);
  }
  EXPECT_EQ(n, 0u);
}

}  // namespace
}  // namespace peha::runtime
