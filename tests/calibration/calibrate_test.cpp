#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/experiments/calibration_recording/excitation.hpp"
#include "peha/config/reader.hpp"

#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>
#include <gmock/gmock.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>
#include <string>

namespace peha::calibration {
namespace {

using ::testing::HasSubstr;

/// 60 s at 250 Hz of a muscle whose true law has a pressure threshold the Tendon-spring model cannot
/// represent: P = F / g(eps) + threshold(eps), threshold 40 kPa rising with contraction. A triangle
/// in force and a slow sweep in contraction; 1 kPa sensor noise.
Dataset synthetic_threshold_muscle() {
  const models::TendonSpringParams truth = testing::dmsp40_nominal();
  Dataset d;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 1e3);
  for (int i = 0; i <= 15000; ++i) {
    const double t = i / 250.0;
    const double eps = 0.05 + 0.1 * (0.5 + 0.5 * std::sin(2 * M_PI * t / 17.0));
    const double phase = std::fmod(t, 12.0) / 12.0;
    const double force = 150.0 + 900.0 * (phase < 0.5 ? 2 * phase : 2 - 2 * phase);
    const double threshold_Pa = 40e3 + 200e3 * eps * eps;
    const double P = models::inverse_pressure(truth, force, eps, 0.8e6).pressure_Pa + threshold_Pa;
    d.t_s.push_back(t);
    d.contraction.push_back(eps);
    d.force_N.push_back(force);
    d.pressure_Pa.push_back(P + noise(rng));
  }
  d.source = "synthetic";
  d.sha256 = "0";
  return d;
}

CalibrateOptions fast_options() {
  CalibrateOptions o;
  o.muscle = "test";
  o.fit.restarts = 12;
  o.spgp.num_pseudo = 20;
  o.spgp.max_iterations = 150;
  return o;
}

// The SPGP learns what the parametric model cannot: on held-out time blocks the pressure error with
// the SPGP is well below the parametric one (here the threshold leaves ~10 kPa to the parametric
// model; the SPGP gets within a few times the 1 kPa noise).
TEST(Calibrate, SpgpRemovesTheThresholdTheParametricModelMisses) {
  const CalibrationOutcome out = calibrate(synthetic_threshold_muscle(), fast_options());
  const CalibrationStats& s = out.calibration.stats;
  EXPECT_EQ(s.rows_heldout, 3000u);  // every fifth of 50 blocks
  EXPECT_EQ(s.rows_train + s.rows_heldout, 15001u);
  EXPECT_GT(s.heldout_rms_parametric_Pa, 3e3);
  EXPECT_LT(s.heldout_rms_spgp_Pa, 0.5 * s.heldout_rms_parametric_Pa);
  EXPECT_LT(s.heldout_rms_spgp_Pa, 4e3);
  // Held-out rows are ten time-contiguous runs of 300 rows, spread over the whole recording (so no
  // segment of an excitation is held out whole).
  int runs = 0;
  for (std::size_t i = 0; i < out.heldout.size(); ++i) runs += out.heldout[i] && (i == 0 || !out.heldout[i - 1]);
  EXPECT_EQ(runs, 10);
}

// Too few rows left to fit after the held-out split is the data's fault (a DataError: exit 2 at the
// command line), said before any fit: 5 rows of a static map lose one to the held-out levels and
// the 4 left cannot fix 5 parameters; 60 rows leave 48, fewer than 50 pseudo-inputs.
TEST(Calibrate, TooFewRowsLeftToFitIsADataError) {
  const Dataset all = synthetic_threshold_muscle();
  const auto first_rows = [&](std::size_t n) {
    Dataset d;
    d.contraction.assign(all.contraction.begin(), all.contraction.begin() + static_cast<std::ptrdiff_t>(n));
    d.force_N.assign(all.force_N.begin(), all.force_N.begin() + static_cast<std::ptrdiff_t>(n));
    d.pressure_Pa.assign(all.pressure_Pa.begin(), all.pressure_Pa.begin() + static_cast<std::ptrdiff_t>(n));
    d.source = "map.csv";
    return d;
  };
  CalibrateOptions o = fast_options();
  try {
    (void)calibrate(first_rows(5), o);
    ADD_FAILURE() << "5 rows calibrated";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("map.csv: 5 rows leave 4 to fit after 1 held out; the Tendon-spring fit needs at least 5"));
  }
  o.spgp.num_pseudo = 50;
  try {
    (void)calibrate(first_rows(60), o);
    ADD_FAILURE() << "60 rows calibrated with 50 pseudo-inputs";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("60 rows leave 48 to fit after 12 held out, fewer than the SPGP's 50 pseudo-inputs"));
  }
  o.holdout = false;
  o.use_spgp = false;
  EXPECT_EQ(calibrate(first_rows(5), o).calibration.stats.rows_train, 5u);
}

/// The synthetic muscle's data as a recorded CSV (read back: a calibration file names its data).
Dataset synthetic_threshold_muscle_file(const std::filesystem::path& csv) {
  write_dataset(csv, synthetic_threshold_muscle(), {"synthetic threshold muscle"});
  return read_dataset(csv);
}

// A calibration file written and read back predicts exactly what the fitted model predicts.
TEST(CalibrationFile, RoundTripPreservesPredictions) {
  const auto csv = std::filesystem::temp_directory_path() / ("peha_calibration_roundtrip.csv_" + std::to_string(::getpid()));
  const CalibrationOutcome out = calibrate(synthetic_threshold_muscle_file(csv), fast_options());
  const auto path = std::filesystem::temp_directory_path() / ("peha_calibration_roundtrip.yaml_" + std::to_string(::getpid()));
  write_calibration(path, out.calibration);
  const MuscleCalibration back = read_calibration(path);
  ASSERT_TRUE(back.spgp);
  // The file carries a in N/MPa: a * 1e6 read back times 1e-6 is the same number to an ulp or two,
  // not always bit for bit (round-off of the two scalings).
  EXPECT_DOUBLE_EQ(back.params.a_N_per_Pa, out.calibration.params.a_N_per_Pa);
  EXPECT_EQ(back.params.k_N, out.calibration.params.k_N);
  for (double eps : {0.06, 0.1, 0.14}) {
    for (double F : {200.0, 600.0, 1000.0}) {
      const double x[2] = {eps, F};
      EXPECT_DOUBLE_EQ(back.spgp->predict_mean(x), out.calibration.spgp->predict_mean(x));
      EXPECT_NEAR(back.spgp->predict_variance(x), out.calibration.spgp->predict_variance(x),
                  1e-9 * std::abs(out.calibration.spgp->predict_variance(x)) + 1e-12);
    }
  }
  EXPECT_EQ(back.stats.rows_heldout, out.calibration.stats.rows_heldout);
  EXPECT_EQ(back.residual_Pa.min, out.calibration.residual_Pa.min);
  EXPECT_EQ(back.residual_Pa.max, out.calibration.residual_Pa.max);
  EXPECT_LT(back.residual_Pa.min, 0.0);
  EXPECT_GT(back.residual_Pa.max, 0.0);
  // The controller's residual is the SPGP's mean inside the data's box, and the mean at the box's
  // nearest edge outside it (no extrapolation).
  const SpgpResidual residual(back.spgp, back.contraction, back.force_N, back.residual_Pa);
  const double inside[2] = {0.5 * (back.contraction.min + back.contraction.max), 0.5 * (back.force_N.min + back.force_N.max)};
  EXPECT_EQ(residual.pressure_Pa(inside[0], inside[1]), back.spgp->predict_mean(inside));
  const double edge[2] = {back.contraction.max, back.force_N.min};
  EXPECT_EQ(residual.pressure_Pa(back.contraction.max + 0.05, back.force_N.min - 100.0), back.spgp->predict_mean(edge));
  // ... and never a correction larger than the data's residual range: with the range narrowed to
  // +-1 Pa the same SPGP is held at it.
  const SpgpResidual narrow(back.spgp, back.contraction, back.force_N, Span{-1.0, 1.0});
  EXPECT_LE(std::abs(narrow.pressure_Pa(inside[0], inside[1])), 1.0);
  EXPECT_GT(std::abs(back.spgp->predict_mean(inside)), 1.0);
  std::filesystem::remove(path);
  std::filesystem::remove(csv);
}

TEST(CalibrationFile, RejectsEditedFilesWithFileLineAndKey) {
  const auto csv = std::filesystem::temp_directory_path() / ("peha_calibration_bad.csv_" + std::to_string(::getpid()));
  const CalibrationOutcome out = calibrate(synthetic_threshold_muscle_file(csv), fast_options());
  const auto path = std::filesystem::temp_directory_path() / ("peha_calibration_bad.yaml_" + std::to_string(::getpid()));
  write_calibration(path, out.calibration);
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const auto alpha = text.find("alpha:");
  ASSERT_NE(alpha, std::string::npos);
  text.insert(alpha, "unexpected: 1\n  ");  // an unknown key inside spgp
  { std::ofstream(path) << text; }
  try {
    read_calibration(path);
    FAIL() << "an unknown key must be rejected";
  } catch (const config::Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("spgp.unexpected: unknown key"));
    EXPECT_THAT(std::string(e.what()), HasSubstr(path.filename().string() + ":"));
  }
  std::filesystem::remove(path);
  std::filesystem::remove(csv);
}

TEST(Calibrate, RejectsABadSplit) {
  CalibrateOptions o = fast_options();
  o.time_split.heldout_blocks = {o.time_split.blocks};
  o.row_split.heldout_blocks = {o.row_split.blocks};
  EXPECT_THROW(calibrate(synthetic_threshold_muscle(), o), std::invalid_argument);
}

TEST(Excitation, TriangleAndAntiphaseReachTheirEnds) {
  experiments::ExcitationParams e;
  e.min_pressure_Pa = 0.1e6;
  e.max_pressure_Pa = 0.5e6;
  e.period_s = 10.0;
  e.other_pressure_Pa = 0.1e6;
  e.other_pressure_at_min_Pa = 0.3e6;
  EXPECT_DOUBLE_EQ(experiments::triangle_pressure_Pa(e, 0.0), 0.1e6);
  EXPECT_DOUBLE_EQ(experiments::triangle_pressure_Pa(e, 5.0), 0.5e6);
  EXPECT_DOUBLE_EQ(experiments::triangle_pressure_Pa(e, 2.5), 0.3e6);
  EXPECT_DOUBLE_EQ(experiments::triangle_pressure_Pa(e, 12.5), 0.3e6);
  EXPECT_DOUBLE_EQ(experiments::other_pressure_Pa(e, 0.0), 0.3e6);  // antiphase
  EXPECT_DOUBLE_EQ(experiments::other_pressure_Pa(e, 5.0), 0.1e6);
}

}  // namespace
}  // namespace peha::calibration

namespace peha::calibration {
namespace {

// The wire parameters stay physical even when the data cannot tell a stiff wire from a rigid one
// (the threshold data above carry no wire stretch): k within [1e3, 1e8] N, |eps0| <= 0.05.
TEST(Calibrate, FittedWireParametersStayWithinPhysicalBounds) {
  const CalibrationOutcome out = calibrate(synthetic_threshold_muscle(), fast_options());
  EXPECT_GE(out.calibration.params.k_N, 1e3);
  EXPECT_LE(out.calibration.params.k_N, 1e8 * (1 + 1e-9));
  EXPECT_LE(std::abs(out.calibration.params.eps0), 0.05 + 1e-12);
}

}  // namespace
}  // namespace peha::calibration
