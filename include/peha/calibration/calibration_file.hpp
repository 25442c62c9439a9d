#pragma once
/// \file
/// One muscle's calibration file (docs/calibration.md): the Tendon-spring parameters, the SPGP residual
/// (pseudo-inputs, hyperparameters, alpha, the variance matrix, its scaling), the input ranges the
/// data covered, fit statistics and the data file's hash. YAML, written at full precision and read
/// back through the strict config reader (unknown keys, wrong shapes and out-of-range values are
/// rejected with file:line:column).

#include "peha/calibration/spgp.hpp"
#include "peha/models/joint.hpp"

#include <filesystem>
#include <memory>
#include <stdexcept>
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
  /// The load cell's reading with the muscle vented when the data were recorded (subtracted from the
  /// data's forces, so the fitted model is in true force), N; 0 for untared data.
  double loadcell_zero_N = 0.0;
  models::TendonSpringParams params;        ///< the fitted Tendon-spring parameters
  std::shared_ptr<const Spgp> spgp;         ///< residual in Pa over x = (eps, force_N); may be null
  Span contraction, force_N, pressure_Pa;   ///< ranges the training data covered
  /// The parametric model's pressure residual P - g^-1(F; eps) over the training data, Pa: the SPGP
  /// (fitted to it) never corrects by more than the data ever needed (SpgpResidual clamps to it).
  Span residual_Pa;
  CalibrationStats stats;
};

/// Writes `c` atomically (throws on I/O failure), with its integrity section: the SHA-256 of each
/// section's canonical values (the data section carries the data file's SHA-256) and one over them.
void write_calibration(const std::filesystem::path& path, const MuscleCalibration& c);

/// Reads a calibration file; throws config::Error naming file, line, key for a malformed file, and
/// CalibrationRejected when its integrity section is absent (a file from before it existed), a
/// section's values differ from their recorded hash (an edit), an announced section is missing (a
/// file cut off), or its data file is missing or changed (docs/calibration.md#integrity).
MuscleCalibration read_calibration(const std::filesystem::path& path);

/// Tolerances of the checks a calibration passes before it is used.
struct CalibrationCheckLimits {
  /// The configured (nominal) model of the muscle, driven at the pressure the calibrated model
  /// commands for any force up to the ceiling, may not predict more than this times the ceiling.
  /// The hazard is a weaker muscle's model on a stronger muscle (2849 N held for a 630 N ceiling);
  /// a calibration of this muscle may differ from the configured model by a factor at low force
  /// (slack, threshold) and by half beyond its data (a 15 % weaker muscle's calibration: 1.52 x at
  /// 1950 N), so the comparison is against twice the ceiling: the antagonist's model on the agonist
  /// drives it to supply, where the configured model predicts 4900 N (2.45 x).
  double nominal_force_ratio = 2.0;
  /// |SPGP residual| anywhere in the operating range, as a fraction of the supply pressure. A residual
  /// as large as the supply is no muscle's: an edited or corrupted file. Judged where the SPGP has
  /// data (see max_supported_std_fraction); finite everywhere.
  double max_residual_of_supply = 1.0;
  /// A grid point is where the SPGP has data when its predictive std is at most this fraction of the
  /// supply (40 kPa at 0.8 MPa; at the operating points the recording visits it is 0.5-3 kPa, 28-59
  /// kPa where it never went). Elsewhere in the data's box (the recording is a band in (contraction,
  /// force), its box mostly empty) the residual is the GP's extrapolation of its trend: a fitted one
  /// reached -0.92 MPa there (std 79 kPa) on robustness variants.
  double max_supported_std_of_supply = 0.05;
  /// The calibrated muscle's force at full supply, at any angle of the range, is within
  /// [1/this, this] x the configured muscle's there (where that is at least a tenth of its ceiling).
  /// The configured model is the muscle's geometry (datasheet diameter, length, braid); a fitted one
  /// differs from it by what the rig adds (slack, friction, a 15 % weaker or stronger muscle):
  /// docs/calibration.md gives the measured ratios. A force model scaled by 4 or more is no muscle
  /// of this size.
  double max_strength_ratio = 3.0;
  int grid = 41;                    ///< points per axis of the operating-range grid
};

/// Why a calibration was refused: file, muscle, and the first failed check with its values.
class CalibrationRejected : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Checks calibration `c` (read from `path`) before it replaces muscle `side` (0 agonist, 1
/// antagonist) of `joint`, over the operating range: joint angles [min_angle_rad, max_angle_rad]
/// and forces [0, the muscle's ceiling]. Refuses (throws CalibrationRejected) when
///  - the file's muscle is not this muscle (swapped files);
///  - the muscle's force at full supply is outside [1/max_strength_ratio, max_strength_ratio] x the
///    configured muscle's somewhere in the range (a scaled force model);
///  - any parameter, g(u) or a model output is not finite, or g(u) <= 0 where the controller works
///    (the inverse would command full supply);
///  - the configured model of this muscle, at the pressure the calibration commands, predicts more
///    than nominal_force_ratio x its ceiling (a calibration of a weaker muscle on a stronger one);
///  - the SPGP residual is not finite, or exceeds max_residual_of_supply x supply where the SPGP has
///    data, or the SPGP has data nowhere on the grid (with_spgp only).
void check_calibration(const MuscleCalibration& c, const std::filesystem::path& path, bool with_spgp,
                       const models::JointModel& joint, int side, double min_angle_rad, double max_angle_rad,
                       const CalibrationCheckLimits& limits = {});

/// `muscle` with calibration `c`'s Tendon-spring parameters and (when `with_spgp`) its SPGP residual,
/// unchecked: for evaluating a calibration's model (reports, plots, the Python module). A joint the
/// controller and the limits use takes a calibration only through apply_calibration.
models::MuscleModel calibrated_muscle(const MuscleCalibration& c, bool with_spgp, models::MuscleModel muscle);

/// Puts calibration `c` (read from `path`) into muscle `side` of `joint` after check_calibration:
/// its Tendon-spring parameters, and its SPGP as the pressure residual when `with_spgp` (else no
/// residual). The one place a calibration enters a joint model; controller and limits then both
/// read the same muscle. Throws CalibrationRejected and leaves `joint` unchanged when a check fails.
void apply_calibration(const MuscleCalibration& c, const std::filesystem::path& path, bool with_spgp,
                       models::JointModel& joint, int side, double min_angle_rad, double max_angle_rad);

/// The SPGP as the controller's pressure residual: pressure_Pa(eps, F) = spgp.predict_mean({eps, F})
/// with (eps, F) clamped to the box the calibration data covered, and the result clamped to the
/// residual range the training data had. A GP extrapolates freely (the antagonist's residual reached
/// -0.45 MPa at a contraction 0.01 beyond its data); clamped, the residual outside the data is the
/// one at the nearest edge of what was measured. The box's corners can still be far from any row
/// (the agonist's data at its least contraction carry little force): there the SPGP's mean asked
/// +0.5 MPa at 1200 N, four times the pressure the muscle needs, and the output clamp holds it to
/// the largest correction the data ever needed.
class SpgpResidual final : public models::PressureResidual {
 public:
  SpgpResidual(std::shared_ptr<const Spgp> spgp, Span contraction, Span force_N, Span residual_Pa)
      : spgp_(std::move(spgp)), contraction_(contraction), force_N_(force_N), residual_Pa_(residual_Pa) {}
  double pressure_Pa(double eps, double force_N) const noexcept override {
    const double x[2] = {clamp(eps, contraction_), clamp(force_N, force_N_)};
    return clamp(spgp_->predict_mean(x), residual_Pa_);
  }
  void pressure_pair_Pa(double eps, double force_a_N, double force_b_N, double out[2]) const noexcept override {
    const double e = clamp(eps, contraction_);
    const double xa[2] = {e, clamp(force_a_N, force_N_)};
    const double xb[2] = {e, clamp(force_b_N, force_N_)};
    spgp_->predict_mean_pair(xa, xb, out);
    out[0] = clamp(out[0], residual_Pa_);
    out[1] = clamp(out[1], residual_Pa_);
  }
  void bounds_Pa(double& lo, double& hi) const noexcept override {
    lo = residual_Pa_.min;
    hi = residual_Pa_.max;
  }

 private:
  static double clamp(double v, const Span& s) noexcept { return v < s.min ? s.min : (v > s.max ? s.max : v); }
  std::shared_ptr<const Spgp> spgp_;
  Span contraction_, force_N_, residual_Pa_;
};

}  // namespace peha::calibration
