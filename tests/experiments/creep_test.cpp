// The wire-creep experiment (experiments/creep, docs/creep.md) in a short version: 4 simulated
// minutes instead of 30, the wires creeping 25x E1's plant so that the truth passes the alert
// threshold within the run. The full run is `peha run --config configs/e1_creep.yaml`.
#include "peha/experiments/creep/creep.hpp"

#include <gtest/gtest.h>

namespace peha {
namespace {

experiments::CreepScenario short_scenario() {
  experiments::CreepScenario s =
      experiments::read_creep(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_creep.yaml"));
  s.e1.duration_s = 240.0;
  s.creep.convergence_s = 60.0;
  for (auto* m : {&s.e1.plant.joint.agonist, &s.e1.plant.joint.antagonist}) m->cable.creep_m_per_N_s = 5e-8;
  return s;
}

/// Both muscles calibrated on the nominal plant (the scenario's creep.calibration, wires not yet
/// crept), then pure feed-forward with the estimator off and on.
std::vector<experiments::CreepRun> run_pure_feed_forward(const experiments::CreepScenario& s) {
  const experiments::PlantVariant nominal{.name = "nominal"};
  const control::OneDofControllerModel calibrated = experiments::creep_calibrated_scenario(s, nominal).controller;
  return {experiments::run_creep_case(s, s.e1.cases.front(), nominal, 0.0, false, &calibrated),
          experiments::run_creep_case(s, s.e1.cases.front(), nominal, 0.0, true, &calibrated)};
}

// Pure feed-forward (trim 0): the estimate follows the agonist's true creep (about 4 mm) within the
// verdict's 0.5 mm RMS (its lag at 25x E1's creep is most of the error) and the antagonist's (0.7 mm),
// the agonist's recalibrate alert latches after the truth crossed 1 mm and within the allowed delay,
// the antagonist's (below 1 mm) does not, and the correction cuts the agonist's force-tracking error
// below 0.8 x the estimator-off run; no supervisor fault: the whole verdict passes.
TEST(CreepExperiment, EstimatorTracksCreepAndCutsTheTrackingErrorOnPureFeedForward) {
  const experiments::CreepScenario s = short_scenario();
  const std::vector<experiments::CreepRun> runs = run_pure_feed_forward(s);
  const experiments::CreepRun& off = runs[0];
  const experiments::CreepRun& on = runs[1];
  EXPECT_GT(on.final_truth_m[0], 0.003);  // the agonist's wire crept more than 3 mm
  EXPECT_LT(on.estimate_rms_m[0], 0.0005);
  EXPECT_LT(on.estimate_max_m[0], 0.001);
  EXPECT_LT(on.estimate_rms_m[1], 0.0005);
  ASSERT_GE(on.truth_cross_s[0], 0.0);
  EXPECT_GE(on.alert_time_s[0], on.truth_cross_s[0]);
  EXPECT_LT(on.alert_time_s[0], on.truth_cross_s[0] + s.creep.verdict.max_alert_delay_s);
  EXPECT_LT(on.alert_time_s[1], 0.0);  // the antagonist's wire did not reach 1 mm: no alert
  EXPECT_LT(on.tracking_rms_last_quarter_N[0], 0.8 * off.tracking_rms_last_quarter_N[0]);
  const safety::Verdict v = experiments::creep_verdict(s, runs);
  EXPECT_TRUE(v.passed()) << v.describe_all();
}

// The figures can fail: an estimator whose gain is 0 never leaves its reference, one with the wrong
// sign runs away from the truth; either fails the estimate-error checks of the verdict.
TEST(CreepExperiment, BrokenEstimatorFailsTheVerdict) {
  // The calibration and the estimator-off run do not depend on the estimator's gain: made once.
  const experiments::CreepScenario nominal_scenario = short_scenario();
  const experiments::PlantVariant nominal{.name = "nominal"};
  const control::OneDofControllerModel calibrated = experiments::creep_calibrated_scenario(nominal_scenario, nominal).controller;
  const experiments::CreepRun off =
      experiments::run_creep_case(nominal_scenario, nominal_scenario.e1.cases.front(), nominal, 0.0, false, &calibrated);
  for (double gain : {0.0, -1.0}) {
    experiments::CreepScenario s = nominal_scenario;
    s.e1.controller.creep.gain_scale = gain;
    control::OneDofControllerModel broken = calibrated;  // the calibrated controller carries the estimator's parameters
    broken.creep.gain_scale = gain;
    const std::vector<experiments::CreepRun> runs = {off, experiments::run_creep_case(s, s.e1.cases.front(), nominal, 0.0, true, &broken)};
    const safety::Verdict v = experiments::creep_verdict(s, runs);
    EXPECT_FALSE(v.passed()) << gain;
    const safety::Check* rms = v.find("nominal_trim0_on agonist creep estimate RMS error");
    ASSERT_NE(rms, nullptr);
    EXPECT_FALSE(rms->passed()) << gain << ": " << rms->describe();
    EXPECT_GT(runs[1].estimate_rms_m[0], 0.001) << gain;
  }
}

TEST(CreepExperiment, ScenarioRepeatsThePushesOverTheRun) {
  const experiments::CreepScenario s =
      experiments::read_creep(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_creep.yaml"));
  EXPECT_GE(s.e1.duration_s, 1800.0);
  // The start-up hold, then an up and a down push every 20 s: 89 or 90 of each in 30 min.
  EXPECT_GE(s.e1.plant.finger.pushes.size(), 1u + 2u * 89u);
  EXPECT_EQ(s.e1.plant.finger.pushes.size(), s.e1.probe_direction.size());
  EXPECT_GE(s.e1.plant.joint.agonist.cable.creep_m_per_N_s, 5 * 2e-9);
  EXPECT_EQ(s.creep.force_trim_rates_1ps.size(), 2u);
  EXPECT_TRUE(s.creep.calibrate);
  EXPECT_TRUE(s.e1.controller.creep.enabled);
}

}  // namespace
}  // namespace peha
