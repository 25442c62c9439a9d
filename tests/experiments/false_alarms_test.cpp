#include "peha/experiments/false_alarms/false_alarms.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>

namespace peha::experiments {
namespace {

using ::testing::HasSubstr;

std::size_t index_of(std::uint32_t flag) { return static_cast<std::size_t>(std::countr_zero(flag)); }

/// E1 (both payloads) shortened to its start-up, hold and first push (9 s), seeds 1-2, noise x1 and x3.
FalseAlarmConfig short_e1() {
  FalseAlarmConfig c;
  c.cases = {{"e1", FalseAlarmRun::kE1, PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml", {}}};
  c.noise_scales = {1.0, 3.0};
  c.seeds = 2;
  c.variant_seeds = 0;
  c.e1_duration_s = 9.0;
  return c;
}

const CheckStatistics& stats(const FalseAlarmResult& r, std::size_t group, std::uint32_t flag) {
  return r.groups.at(group).checks.at(index_of(flag));
}

// The short version `make test` runs (make false-alarms runs the full one): on fault-free E1 no
// check trips at x1 or x3 sensor noise, and at x1 every check that compared anything keeps the 1.5x
// margin. The noise-driven checks did compare: a run that measured nothing would pass vacuously.
TEST(FalseAlarms, ShortE1RunsTripNoCheckAndKeepTheMargin) {
  const FalseAlarmResult r = run_false_alarms(short_e1());
  ASSERT_EQ(r.rows.size(), 2u * 2u * 2u);  // payloads x seeds x noise scales
  EXPECT_TRUE(r.passed()) << ::testing::PrintToString(r.failures);
  for (std::uint32_t flag : {safety::kFaultPressureRise, safety::kFaultLoadcellStep, safety::kFaultLoadcellDisagrees,
                             safety::kFaultPressureHigh, safety::kFaultJointSpeed, safety::kFaultTensionFloor}) {
    const CheckStatistics& s = stats(r, 0, flag);
    EXPECT_EQ(s.runs, 4u) << safety::fault_flag_name(flag);
    EXPECT_GT(s.max_ratio, 0.0) << safety::fault_flag_name(flag);
    EXPECT_LE(s.max_ratio, 1.0 / 1.5) << safety::fault_flag_name(flag);
  }
  // More noise, a larger ratio for the noise-driven check.
  EXPECT_GT(stats(r, 1, safety::kFaultPressureRise).max_ratio, stats(r, 0, safety::kFaultPressureRise).max_ratio);
}

// E4's runs complete: the job once held MuJoCo's loading lock around the door, whose simulated arm
// takes it again, and the whole tool hung on its first E4 case. Both movements, one seed, x1 noise
// (a second each): they compared and tripped nothing.
TEST(FalseAlarms, AnE4CaseRunsBothMovementsToTheirEnd) {
  FalseAlarmConfig c;
  c.cases = {{"e4", FalseAlarmRun::kGoniometer, PEHA_SOURCE_DIR "/configs/right_arm.yaml", {}}};
  c.noise_scales = {1.0};
  c.seeds = 1;
  c.variant_seeds = 0;
  const FalseAlarmResult r = run_false_alarms(c);
  ASSERT_EQ(r.rows.size(), 2u);  // slow, brisk
  for (const FalseAlarmRow& row : r.rows) EXPECT_GT(row.duration_s, 10.0) << row.case_name;
  EXPECT_GT(stats(r, 0, safety::kFaultLoadcellDisagrees).max_ratio, 0.0);
  EXPECT_TRUE(r.passed()) << ::testing::PrintToString(r.failures);
}

// A case may skip plant variants where its own controller, not the monitor, is what fails (each with
// its reason in the file); a skip that names no variant the file runs is refused by name.
TEST(FalseAlarms, ACaseSkipsOnlyVariantsTheFileRuns) {
  auto config_with = [](const std::string& skip) {
    const std::string yaml = "experiment: false_alarms\ndescription: skip\nseed: 1\ncases:\n"
                             "  - name: e4\n    run: goniometer\n    scenario: " PEHA_SOURCE_DIR "/configs/right_arm.yaml\n    skip_variants:\n"
                             "      - {name: " + skip + ", why: test}\n"
                             "noise_scales: [1]\nseeds: 1\nvariants_from: " PEHA_SOURCE_DIR "/configs/robustness.yaml\nvariant_seeds: 1\nthreads: 1\n";
    return read_false_alarms(config::Document::load_string(yaml, "false_alarms_test.yaml"));
  };
  const FalseAlarmConfig c = config_with("cable_friction_x0");
  ASSERT_EQ(c.cases.size(), 1u);
  EXPECT_EQ(c.cases[0].skip_variants, std::vector<std::string>{"cable_friction_x0"});
  EXPECT_TRUE(std::any_of(c.variants.begin(), c.variants.end(), [](const PlantVariant& v) { return v.name == "cable_friction_x0"; }));
  try {
    config_with("cable_friction_x9");
    ADD_FAILURE() << "an unknown variant was accepted";
  } catch (const config::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("skips variant 'cable_friction_x9'"));
  }
}

// The verdict can fail: a loadcell_step threshold at the noise the pressure model makes of the
// pressure sensors' (5 N instead of 100) trips on fault-free runs, and the tool reports it as false
// alarms of that check.
TEST(FalseAlarms, AThresholdSetTooTightIsReportedAsFalseAlarms) {
  FalseAlarmConfig c = short_e1();
  c.noise_scales = {1.0};
  c.seeds = 1;
  c.adjust_thresholds = [](safety::MonitorParams& p) { p.loadcell_step_N = 5.0; };
  const FalseAlarmResult r = run_false_alarms(c);
  EXPECT_FALSE(r.passed());
  const CheckStatistics& s = stats(r, 0, safety::kFaultLoadcellStep);
  EXPECT_EQ(s.trips, 2u);  // both payloads
  EXPECT_GT(s.max_ratio, 1.0);
  EXPECT_GT(s.rate_per_h, 100.0);  // at least the observed 2 trips in 18 s
  ASSERT_FALSE(r.failures.empty());
  EXPECT_THAT(r.failures.front(), HasSubstr("loadcell_step x1: 2 trip(s)"));
}

// A check that does not trip but comes within the margin fails the verdict at x1 and is only
// reported at a noise scale the verdict does not judge for margin; the 99th percentile and the
// Gumbel rate come from the runs' peaks (100 runs of 10 s, ratios 0.008..0.8: p99 0.792;
// a law whose upper tail reaches 1: a rate well above 0).
TEST(FalseAlarms, AMarginBelowTheGoalFailsAtNominalNoiseOnly) {
  FalseAlarmConfig c;
  c.noise_scales = {1.0, 3.0, 10.0};
  std::vector<FalseAlarmRow> rows;
  for (int i = 1; i <= 100; ++i) {
    for (double k : {1.0, 10.0}) {
      FalseAlarmRow row;
      row.case_name = "synthetic";
      row.variant = "nominal";
      row.noise_scale = k;
      row.seed = static_cast<std::uint64_t>(i);
      row.duration_s = 10.0;
      row.peaks[index_of(safety::kFaultLoadcellStep)] = 0.008 * i;
      rows.push_back(row);
    }
  }
  const FalseAlarmResult r = judge_false_alarms(c, rows);
  ASSERT_EQ(r.failures.size(), 1u) << ::testing::PrintToString(r.failures);
  EXPECT_THAT(r.failures.front(), HasSubstr("loadcell_step x1: margin 1.25 < 1.5"));
  const CheckStatistics& s = stats(r, 0, safety::kFaultLoadcellStep);
  EXPECT_EQ(s.runs, 100u);
  EXPECT_EQ(s.trips, 0u);
  EXPECT_NEAR(s.p99_ratio, 0.008 * 99.01, 1e-9);
  EXPECT_GT(s.rate_per_h, 0.1);
  EXPECT_EQ(stats(r, 1, safety::kFaultLoadcellStep).runs, 0u);  // no x3 rows
}

}  // namespace
}  // namespace peha::experiments
