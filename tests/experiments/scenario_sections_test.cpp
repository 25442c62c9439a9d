// The two fault authorities have two names in a scenario: `plausibility:` (safety::FaultMonitor)
// and `lifecycle:` (runtime::Supervisor, in process and on the board). A file in the older format is
// refused whole, naming where each key went.
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include "../support/edited_config.hpp"
#include "../support/shipped_scenarios.hpp"

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
  EXPECT_EQ(shipped.limits.monitor.unmodelled, 0u);  // every check on
  const E1Scenario slower = read_e1(config::Document::load_file(e1.write_replacing("  host_watchdog_ms: 20.0", "  host_watchdog_ms: 40.0")));
  EXPECT_DOUBLE_EQ(slower.lifecycle.host_watchdog_s, 0.04);
  const ArmScenario arm = peha::test_support::shipped_right_arm();
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

// No scenario switches the plausibility monitor off, and no watchdog or threshold goes beyond its hard
// bound in code: each is refused naming the key (a stuck valve with the monitor off gave 2302 N and
// 764 deg/s; a 10 s board watchdog was accepted before).
TEST(ScenarioSections, SupervisionCannotBeSwitchedOffOrLoosenedBeyondItsBounds) {
  testing::EditedConfig e1("e1_one_dof.yaml", "bounds");
  const struct {
    std::string from, to, says;
  } refused[] = {
      {"plausibility:\n", "plausibility:\n  enabled: false\n", "plausibility.enabled"},
      {"plausibility:\n", "plausibility:\n  enabled: true\n", "cannot be switched off from a scenario"},
      {"  board_watchdog_ms: 50.0", "  board_watchdog_ms: 10000.0", "mfb.board_watchdog_ms"},
      {"  board_watchdog_ms: 50.0", "  board_watchdog_ms: 101.0", "100"},
      {"  host_watchdog_ms: 20.0", "  host_watchdog_ms: 500.0", "lifecycle.host_watchdog_ms"},
      {"  recovery_ramp_s: 1.0", "  recovery_ramp_s: 0.0", "lifecycle.recovery_ramp_s"},
      {"  max_joint_speed_degps: 90.0", "  max_joint_speed_degps: 2000.0", "plausibility.max_joint_speed_degps"},
      {"  descent_speed_degps: 11.5", "  descent_speed_degps: 90.0", "plausibility.descent_speed_degps"},
  };
  for (const auto& r : refused) {
    bool found = false;
    const std::filesystem::path edited = e1.write_replacing(r.from, r.to, &found);
    ASSERT_TRUE(found) << r.from;
    try {
      (void)read_e1(config::Document::load_file(edited));
      ADD_FAILURE() << "accepted: " << r.to;
    } catch (const config::Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(r.says)) << r.to;
    }
  }
  // At the bound itself: accepted.
  EXPECT_NO_THROW(read_e1(config::Document::load_file(e1.write_replacing("  board_watchdog_ms: 50.0", "  board_watchdog_ms: 100.0"))));
}

}  // namespace
}  // namespace peha::experiments
