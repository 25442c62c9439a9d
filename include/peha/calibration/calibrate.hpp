#pragma once
/// \file
/// The calibration pipeline of one muscle (SPEC §3): split the data into time-contiguous blocks and
/// hold some out, fit the Tendon-spring parameters (LM, best of N restarts) on the rest, train the
/// SPGP on the parametric model's pressure residual over x = (eps, F), and measure the held-out
/// pressure RMS error of the parametric model alone and of parametric + SPGP.

#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/calibration/spgp.hpp"
#include "peha/calibration/tendon_spring_fit.hpp"

#include <functional>
#include <string>
#include <vector>

namespace peha::calibration {

struct CalibrateOptions {
  std::string muscle = "muscle";
  FitOptions fit;
  SpgpOptions spgp;
  bool use_spgp = true;
  /// The held-out split: the rows, in file order, are cut into `blocks` equal blocks and the
  /// zero-based `heldout_blocks` are held out. Recordings (rows with times) use `time_split`: 50
  /// blocks, every fifth held out (20 %), so each stretch is short (1.7 s of an 84 s excitation)
  /// and no operating-point segment is held out whole - with 10 blocks the agonist's 8 s clamp at
  /// 0 deg fell into one held-out block, the SPGP never saw E1's main hold and was 0.47 MPa wrong
  /// there (muscle +15 %: held-out RMS 184 kPa, parametric 21 kPa). Static force maps (no times,
  /// rows sorted by pressure) use `row_split`: 10 blocks, 2 and 7, so the held-out rows are whole
  /// pressure levels and the test is interpolation between levels, not between neighbouring rows.
  struct Split {
    int blocks = 10;
    std::vector<int> heldout_blocks;
  };
  Split time_split{50, {2, 7, 12, 17, 22, 27, 32, 37, 42, 47}};
  Split row_split{10, {2, 7}};
  bool holdout = true;                 ///< false: fit every row (held-out figures 0)
  std::size_t max_spgp_rows = 20000;   ///< evenly thinned training set for the SPGP beyond this
};

/// Everything a report needs, row by row over the whole dataset.
struct CalibrationOutcome {
  MuscleCalibration calibration;
  std::vector<char> heldout;          ///< 1 where the row was held out
  std::string split;                  ///< e.g. "time-contiguous blocks 2,7 of 10", or "nothing held out"
  std::vector<double> pressure_parametric_Pa;  ///< g^-1(F; eps) per row
  std::vector<double> pressure_spgp_Pa;        ///< g^-1 + SPGP mean per row (= parametric without SPGP)
  std::vector<double> spgp_std_Pa;             ///< SPGP predictive std per row (0 without SPGP)
};

struct CalibrateProgress {
  std::function<void(int done, int total)> restarts;   ///< LM restarts
  std::function<void(int iteration, double nlml)> spgp; ///< SPGP optimiser iterations
};

/// Runs the pipeline; throws std::invalid_argument for bad options (e.g. a held-out block index
/// outside [0, blocks)), and whatever the stages throw.
CalibrationOutcome calibrate(const Dataset& data, const CalibrateOptions& options, const CalibrateProgress& progress = {});

}  // namespace peha::calibration
