// The calibration covers where the controller works: the excitation's operating-point segments
// reach the antagonist's E1 hold point, and the closed-loop check on the rig accepts a fitted
// calibration and refuses a wrong one (docs/calibration.md, "Operating points" and "Acceptance").
#include "peha/calibration/calibrate.hpp"
#include "../support/shipped_scenarios.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/experiments/calibration_recording/acceptance.hpp"
#include "peha/sim/plant_faults.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

namespace peha::experiments {
namespace {

using ::testing::HasSubstr;

/// Rows of the recording in E1's antagonist hold region: contraction of the link between -15 and
/// +25 deg (nominal geometry) and force within 30..100 N around the 60 N pretension.
std::size_t rows_at_hold_point(const calibration::Dataset& d, double t_from_s, double t_to_s) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (d.t_s[i] < t_from_s || d.t_s[i] >= t_to_s) continue;
    n += d.contraction[i] >= 0.0045 && d.contraction[i] <= 0.045 && d.force_N[i] >= 30.0 && d.force_N[i] <= 100.0;
  }
  return n;
}

// The main triangle never brings the antagonist near its pretension after the start-up transient;
// the operating-point segment does, for seconds, without a slack wire.
TEST(CalibrationCoverage, AntagonistRecordingVisitsTheE1HoldPointWithATautWire) {
  const E1Scenario s = test_support::shipped_e1();
  ASSERT_TRUE(s.excitation[1]);
  ASSERT_FALSE(s.excitation[1]->segments.empty());
  const double start_s = s.excitation[1]->excitation_start_s();
  const double main_end_s = start_s + s.excitation[1]->duration_s;
  const double free_end_s = main_end_s + s.excitation[1]->segments[0].duration_s;  // the free segment
  const calibration::Dataset d = record_e1_muscle(s, s.plant, 1);
  EXPECT_NEAR(d.t_s.front(), start_s, 0.01);  // nothing recorded during the tare
  EXPECT_NEAR(d.t_s.back(), s.excitation[1]->total_duration_s(), 0.01);
  EXPECT_EQ(rows_at_hold_point(d, start_s + 1.0, main_end_s), 0u);
  const std::size_t in_segment = rows_at_hold_point(d, main_end_s, free_end_s);
  EXPECT_GT(in_segment, 1250u);  // > 5 s at 250 Hz
  double lowest = 1e9;
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (d.t_s[i] >= main_end_s + 1.0 && d.t_s[i] < free_end_s) lowest = std::min(lowest, d.force_N[i]);
  }
  EXPECT_GT(lowest, 20.0);  // never slack in the segment
}

// The recording tares its load cell first (both muscles vented, the link clamped): a load cell
// reading 40 N high on the plant gives a zero of 40 N (plus what the vented muscle still pulls,
// a few N), and the recorded forces are the true ones, so the fitted model never sees the bias.
TEST(CalibrationCoverage, RecordingTaresTheLoadCellSoABiasDoesNotEnterTheData) {
  const E1Scenario s = test_support::shipped_e1();
  ASSERT_TRUE(s.excitation[1]);
  ASSERT_GT(s.excitation[1]->tare_s, 0.0);
  sim::OneDofRigParams plain = s.plant, biased = s.plant;
  biased.joint.antagonist.loadcell_offset_N += 40.0;
  const calibration::Dataset a = record_e1_muscle(s, plain, 1);
  const calibration::Dataset b = record_e1_muscle(s, biased, 1);
  EXPECT_NEAR(a.loadcell_zero_N, 0.0, 5.0);
  EXPECT_NEAR(b.loadcell_zero_N - a.loadcell_zero_N, 40.0, 0.5);
  ASSERT_EQ(a.size(), b.size());
  // The same plant, the same forces: only the 16-bit quantisation differs - except where the
  // unbiased cell reads near zero and its noise is clipped at the bottom of its range.
  double worst = 0;
  std::size_t compared = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a.force_N[i] < 5.0) continue;
    worst = std::max(worst, std::abs(b.force_N[i] - a.force_N[i]));
    ++compared;
  }
  EXPECT_GT(compared, a.size() * 9 / 10);
  EXPECT_LT(worst, 0.5);
}

// The segment's pressures: each segment starts at its own minimum with the partner at its
// other_pressure_at_min, and reaches its top at half its period.
TEST(CalibrationCoverage, SegmentsFollowTheMainTriangle) {
  ExcitationParams e;
  e.min_pressure_Pa = 0.1e6;
  e.max_pressure_Pa = 0.5e6;
  e.period_s = 10.0;
  e.duration_s = 20.0;
  e.other_pressure_Pa = e.other_pressure_at_min_Pa = 0.3e6;
  e.segments.push_back({0.12e6, 0.30e6, 8.0, 16.0, 0.10e6, 0.16e6});
  EXPECT_DOUBLE_EQ(e.total_duration_s(), 36.0);
  EXPECT_DOUBLE_EQ(triangle_pressure_Pa(e, 15.0), 0.5e6);   // main
  EXPECT_DOUBLE_EQ(other_pressure_Pa(e, 15.0), 0.3e6);
  EXPECT_DOUBLE_EQ(triangle_pressure_Pa(e, 20.0), 0.12e6);  // segment start
  EXPECT_DOUBLE_EQ(other_pressure_Pa(e, 20.0), 0.16e6);
  EXPECT_DOUBLE_EQ(triangle_pressure_Pa(e, 24.0), 0.30e6);  // its top
  EXPECT_DOUBLE_EQ(other_pressure_Pa(e, 24.0), 0.10e6);
}

calibration::CalibrationOutcome fitted_antagonist(const E1Scenario& s) {
  const calibration::Dataset d = record_e1_muscle(s, s.plant, 1);
  calibration::CalibrateOptions o;
  o.muscle = "antagonist";
  o.fit.restarts = 8;
  o.spgp.num_pseudo = 30;
  o.spgp.max_iterations = 100;
  o.max_spgp_rows = 4000;
  return calibration::calibrate(d, o);
}

AcceptanceResult check_with(E1Scenario s, const calibration::MuscleCalibration& c) {
  const safety::JointLimits& range = s.limits.joints[0];
  calibration::apply_calibration(c, "test.yaml", true, s.controller.joint, 1, range.min_angle_rad, range.max_angle_rad);
  return run_acceptance_check(s, *s.acceptance, [](const E1Scenario& sc, const E1Case& c) { return e1_plant_params(sc, c); });
}

// The check judges what the rig's sensors give at E1's holds: the antagonist calibrated on the
// shipped excitation tracks its force request; the same calibration with its gain scaled by 1.5
// (a model that believes the muscle 50 % stronger) under-delivers and is refused, saying why.
TEST(CalibrationAcceptance, AcceptsTheFittedCalibrationAndRefusesAGainScaledOne) {
  E1Scenario s = test_support::shipped_e1();
  ASSERT_TRUE(s.acceptance);
  s.cases = {s.cases.back()};  // one payload keeps the test short
  const calibration::CalibrationOutcome fit = fitted_antagonist(s);
  const AcceptanceResult good = check_with(s, fit.calibration);
  ASSERT_EQ(good.points.size(), s.acceptance->angles_rad.size());
  EXPECT_TRUE(good.passed(1)) << good.failure(1);
  EXPECT_LT(good.force_tracking_rms_N[1], s.acceptance->max_force_tracking_rms_N);
  // Per muscle: the antagonist at 60 N is judged by the floor, the agonist (5 kg: ~650 N) by the
  // fraction of its request.
  EXPECT_DOUBLE_EQ(good.max_rms_N[1], s.acceptance->max_force_tracking_rms_N);
  EXPECT_GT(good.force_request_rms_N[0], 500.0);
  EXPECT_DOUBLE_EQ(good.max_rms_N[0], s.acceptance->max_force_tracking_rms_fraction * good.force_request_rms_N[0]);
  EXPECT_GE(good.min_loadcell_N[1], 30.0);
  for (const AcceptancePoint& p : good.points) EXPECT_NEAR(p.force_cmd_N[1], 60.0, 1.0);  // the pretension request

  calibration::MuscleCalibration wrong = fit.calibration;
  wrong.params.a_N_per_Pa *= 1.5;
  wrong.params.b_N_per_Pa *= 1.5;
  wrong.params.c_N_per_Pa *= 1.5;
  const AcceptanceResult bad = check_with(s, wrong);
  EXPECT_FALSE(bad.passed(1));
  EXPECT_GT(bad.force_tracking_rms_N[1], s.acceptance->max_force_tracking_rms_N);
  EXPECT_THAT(bad.failure(1), HasSubstr("antagonist force tracking RMS"));
}

// The recording is guarded by the checks of the hardware itself: a jumping encoder stops it, and the
// data recorded into the safe state is refused (nothing returned), naming the check.
TEST(CalibrationCoverage, AHardwareFaultStopsTheRecordingAndItsDataIsRefused) {
  const E1Scenario s = test_support::shipped_e1();
  ASSERT_TRUE(s.excitation[0]);
  sim::OneDofRigParams plant = s.plant;
  plant.faults.push_back(sim::parse_fault_spec("encoder_jump@10:joint", sim::one_dof_rig_joint_names(), s.excitation[0]->total_duration_s()));
  try {
    (void)record_e1_muscle(s, plant, 0);
    ADD_FAILURE() << "the recording ran through an encoder jump";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("the plausibility monitor stopped the recording: encoder_jump"));
  }
}

}  // namespace
}  // namespace peha::experiments
