#pragma once
/// \file
/// One muscle's calibration file (SPEC §3.4): the Tendon-spring parameters, the SPGP residual
/// (pseudo-inputs, hyperparameters, alpha, the variance matrix, its scaling), the input ranges the
/// data covered, fit statistics and the data file's hash. YAML, written at full precision and read
/// back through the strict config reader (unknown keys, wrong shapes and out-of-range values are
/// rejected with file:line:column).

#include "peha/calibration/spgp.hpp"
#include "peha/models/joint.hpp"

#include <filesystem>
#include <memory>
#include <string>

namespace peha::calibration {

struct Span {
  double min = 0;
  double max = 0;
};

struct CalibrationStats {
  std::size_t rows_train = 0;
  std::size_t rows_heldout = 0;
  int restarts = 0;
  int restarts_converged = 0;
  double lm_seconds = 0;
  double spgp_seconds = 0;
  double train_rms_parametric_Pa = 0;
  double train_rms_spgp_Pa = 0;
  double heldout_rms_parametric_Pa = 0;  ///< held-out pressure RMS of g^-1 alone
  double heldout_rms_spgp_Pa = 0;        ///< held-out pressure RMS of g^-1 + SPGP
};

struct MuscleCalibration {
  std::string muscle;                       ///< e.g. "agonist"
  std::string data_file;
  std::string data_sha256;
  models::TendonSpringParams params;        ///< the fitted Tendon-spring parameters
  std::shared_ptr<const Spgp> spgp;         ///< residual in Pa over x = (eps, force_N); may be null
  Span contraction, force_N, pressure_Pa;   ///< ranges the training data covered
  CalibrationStats stats;
};

/// Writes `c` (throws on I/O failure).
void write_calibration(const std::filesystem::path& path, const MuscleCalibration& c);

/// Reads a calibration file; throws config::Error naming file, line, key.
MuscleCalibration read_calibration(const std::filesystem::path& path);

/// Puts calibration `c` into muscle `m` of a joint set-up: its Tendon-spring parameters, and its
/// SPGP as the pressure residual when `with_spgp` (else no residual). The one place a calibration
/// enters a joint model; controller and limits then both read the same muscle.
void apply_calibration(const MuscleCalibration& c, bool with_spgp, models::MuscleModel& m);

/// The SPGP as the controller's pressure residual: pressure_Pa(eps, F) = spgp.predict_mean({eps, F}).
class SpgpResidual final : public models::PressureResidual {
 public:
  explicit SpgpResidual(std::shared_ptr<const Spgp> spgp) : spgp_(std::move(spgp)) {}
  double pressure_Pa(double eps, double force_N) const noexcept override {
    const double x[2] = {eps, force_N};
    return spgp_->predict_mean(x);
  }

 private:
  std::shared_ptr<const Spgp> spgp_;
};

}  // namespace peha::calibration
