// The two fault authorities have two names in a scenario: `plausibility:` (safety::FaultMonitor)
// and `lifecycle:` (runtime::Supervisor, in process and on the board). A file in the older format is
// refused whole, naming where each key went.
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include "../support/edited_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace peha::experiments {
namespace {

using ::testing::HasSubstr;

std::string refusal(const std::filesystem::path& config) {
  try {
    (void)read_e1(config::Document::load_file(config));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioSections, LifecycleAndPlausibilityAreReadUnderTheirOwnNames) {
  testing::EditedConfig e1("e1_one_dof.yaml", "sections");
  const E1Scenario shipped = read_e1(config::Document::load_file(e1.write(e1.shipped())));
  EXPECT_DOUBLE_EQ(shipped.lifecycle.host_watchdog_s, 0.02);
  EXPECT_DOUBLE_EQ(shipped.lifecycle.recovery_ramp_s, 1.0);
  EXPECT_TRUE(shipped.limits.monitor.enabled);
  const E1Scenario slower = read_e1(config::Document::load_file(e1.write_replacing("  host_watchdog_ms: 20.0", "  host_watchdog_ms: 40.0")));
  EXPECT_DOUBLE_EQ(slower.lifecycle.host_watchdog_s, 0.04);
  const ArmScenario arm = read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml"));
  EXPECT_DOUBLE_EQ(arm.lifecycle.recovery_ramp_s, 1.0);
}

TEST(ScenarioSections, TheOldSupervisorSectionIsRefusedNamingBothNewOnes) {
  testing::EditedConfig e1("e1_one_dof.yaml", "sections_old");
  bool found = false;
  const std::string message = refusal(e1.write_replacing("\nplausibility:\n", "\nsupervisor:\n", &found));
  ASSERT_TRUE(found);
  EXPECT_THAT(message, HasSubstr("supervisor: this key moved: the plausibility monitor's thresholds are the plausibility: section now"));
  EXPECT_THAT(message, HasSubstr("lifecycle:"));
  EXPECT_THAT(message, HasSubstr("e1_one_dof.yaml:"));  // file:line:column
}

}  // namespace
}  // namespace peha::experiments
