#pragma once
/// \file
/// The false-alarm statistics of the plausibility monitor (docs/safety.md "False alarms"): every
/// check's largest ratio to its threshold (safety::FaultMonitor::peaks) on fault-free runs - E1
/// (every payload), E3 and E4 on the arm scenarios - over seeds (the sensor noise), the plant variants
/// of the robustness matrix and raised sensor noise. Per check and noise level: runs, trips (false
/// alarms), the largest ratio, its 99th percentile, the margin and an estimated false-alarm rate.

#include "peha/config/reader.hpp"
#include "peha/experiments/robustness/robustness.hpp"
#include "peha/safety/fault_monitor.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace peha::experiments {

/// What a false-alarm case runs.
enum class FalseAlarmRun {
  kE1,          ///< E1 gravity compensation, every payload of the scenario (one case each)
  kPostures,    ///< E3 postures on an arm scenario
  kGoniometer,  ///< E4 on an arm scenario, every movement (open loop, the paper's)
};

struct FalseAlarmCase {
  std::string name;  ///< e.g. "e3_right_arm"
  FalseAlarmRun run = FalseAlarmRun::kE1;
  std::filesystem::path scenario;
  /// Plant variants this case does not run: where its controller, not the monitor, is what fails
  /// (each named with its reason in the file).
  std::vector<std::string> skip_variants;
};

struct FalseAlarmConfig {
  std::vector<FalseAlarmCase> cases;
  /// Sensor-noise factors run on the nominal plant, each with `seeds` seeds; the first must be 1.
  std::vector<double> noise_scales{1.0, 3.0, 10.0};
  int seeds = 20;          ///< seeds 1..seeds per case and noise scale
  /// The robustness matrix's plant variants (all but `nominal`), run at x1 noise with variant_seeds each.
  std::vector<PlantVariant> variants;
  int variant_seeds = 5;
  /// Verdict: at x1 (nominal and variants) no trip and every check's peak ratio <= 1 / margin_goal;
  /// at the second noise scale (x3) no trip. Higher scales are reported.
  double margin_goal = 1.5;
  double e1_duration_s = 0;  ///< > 0: shorten E1 (tests); 0: the scenario's
  int threads = 2;
  /// Applied to every case's plausibility thresholds after its scenario is read (a test's too-tight
  /// threshold: the tool must report its trips). Empty: the scenarios' own.
  std::function<void(safety::MonitorParams&)> adjust_thresholds;
};

/// Reads configs/false_alarms.yaml (paths relative to it; `variants_from:` a robustness file whose
/// variants run); throws config::Error.
FalseAlarmConfig read_false_alarms(const config::Document& doc);

/// One fault-free run: which checks latched and every check's peak ratio.
struct FalseAlarmRow {
  std::string case_name;  ///< "e1_payload_5.0kg", "e3_right_arm", "e4_right_arm_brisk", ...
  std::string variant;    ///< "nominal" or the plant variant
  double noise_scale = 1;
  std::uint64_t seed = 1;
  double duration_s = 0;  ///< simulated
  std::uint32_t flags = 0;       ///< safety::FaultFlag bits latched by the end
  std::uint32_t first_flag = 0;  ///< the first of them: the false alarm (the others may follow from its safe state)
  safety::CheckPeaks peaks{};
};

/// One check's statistics over a group of runs (one noise scale; x1 includes the variants).
struct CheckStatistics {
  std::uint32_t flag = 0;
  std::size_t runs = 0;       ///< runs of the group
  std::size_t trips = 0;      ///< runs whose first fault it was: false alarms
  std::size_t later = 0;      ///< runs in which it latched after another check's false alarm
  double max_ratio = 0;       ///< largest peak ratio over the runs
  double p99_ratio = 0;       ///< 99th percentile of the runs' peak ratios
  std::string worst;          ///< the run of max_ratio (case, variant, seed)
  /// Estimated false alarms per hour: a Gumbel distribution fitted (by moments) to the runs' peak
  /// ratios, P(a run's peak >= 1) per run's duration; or the observed trips per hour when larger.
  double rate_per_h = 0;
  double margin() const noexcept { return max_ratio > 0 ? 1.0 / max_ratio : 0.0; }
};

struct FalseAlarmGroup {
  double noise_scale = 1;
  std::vector<CheckStatistics> checks;  ///< one per FaultFlag (bit order)
  double hours = 0;                     ///< simulated hours of the group's runs
  bool judged = false;                  ///< the verdict covers it (x1: trips and margin; x3: trips)
  bool margin_judged = false;
};

struct FalseAlarmResult {
  std::vector<FalseAlarmRow> rows;
  std::vector<FalseAlarmGroup> groups;  ///< one per noise scale
  /// Failed figures: "pressure_rise x1: 2 trips", "loadcell_step x1: margin 1.2 < 1.5".
  std::vector<std::string> failures;
  bool passed() const noexcept { return failures.empty(); }
};

/// The statistics and the verdict of `rows` (exposed for tests).
FalseAlarmResult judge_false_alarms(const FalseAlarmConfig& config, std::vector<FalseAlarmRow> rows);

/// Runs every case x (noise scale x seeds, variant x variant_seeds); `progress(done, total, line)`
/// after each run (serialised).
FalseAlarmResult run_false_alarms(const FalseAlarmConfig& config,
                                  const std::function<void(std::size_t, std::size_t, const std::string&)>& progress = {});

/// false_alarms.csv (one row per run, a column per check) and false_alarms.md (the tables).
void write_false_alarms(const std::filesystem::path& dir, const FalseAlarmConfig& config, const FalseAlarmResult& result);

}  // namespace peha::experiments
