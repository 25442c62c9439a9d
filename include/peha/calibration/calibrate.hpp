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
  int blocks = 10;                     ///< the data (in row order = time order) is cut into this many blocks
  std::vector<int> heldout_blocks = {2, 7};  ///< zero-based blocks held out (20 % by default)
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
