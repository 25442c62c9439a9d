#include "peha/calibration/calibrate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace peha::calibration {
namespace {

double rms(const std::vector<double>& values, const std::vector<char>& mask, char which) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (mask[i] != which) continue;
    sum += values[i] * values[i];
    ++n;
  }
  return n ? std::sqrt(sum / n) : 0.0;
}

Span span_of(const std::vector<double>& v, const std::vector<char>& mask) {
  Span s{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (mask[i]) continue;
    s.min = std::min(s.min, v[i]);
    s.max = std::max(s.max, v[i]);
  }
  return s;
}

}  // namespace

CalibrationOutcome calibrate(const Dataset& data, const CalibrateOptions& options, const CalibrateProgress& progress) {
  const std::size_t n = data.size();
  const CalibrateOptions::Split& split = data.t_s.empty() ? options.row_split : options.time_split;
  static const std::vector<int> kNone;
  const std::vector<int>& heldout_blocks = options.holdout ? split.heldout_blocks : kNone;
  if (split.blocks < 2) throw std::invalid_argument("calibrate: need at least 2 blocks");
  for (int b : heldout_blocks) {
    if (b < 0 || b >= split.blocks) {
      throw std::invalid_argument(fmt::format("calibrate: held-out block {} outside [0, {})", b, split.blocks));
    }
  }
  if (static_cast<int>(heldout_blocks.size()) >= split.blocks) {
    throw std::invalid_argument("calibrate: every block is held out; nothing left to fit");
  }

  CalibrationOutcome out;
  const char* order = data.t_s.empty() ? "row-order" : "time-contiguous";
  out.split = heldout_blocks.empty()
                  ? std::string("nothing held out")
                  : fmt::format("{} blocks {} of {}", order, fmt::join(heldout_blocks, ","), split.blocks);
  out.heldout.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const int block = static_cast<int>(i * static_cast<std::size_t>(split.blocks) / n);
    out.heldout[i] = std::find(heldout_blocks.begin(), heldout_blocks.end(), block) != heldout_blocks.end();
  }

  FitData train;
  for (std::size_t i = 0; i < n; ++i) {
    if (out.heldout[i]) continue;
    train.contraction.push_back(data.contraction[i]);
    train.force_N.push_back(data.force_N[i]);
    train.pressure_Pa.push_back(data.pressure_Pa[i]);
  }
  // Too few rows left to fit is the data's shortfall (exit 2 at the command line), said before any fit runs.
  const std::size_t n_train = train.pressure_Pa.size();
  const std::size_t held = n - n_train;
  if (n_train < kMinFitRows) {
    throw DataError(fmt::format("{}: {} rows leave {} to fit after {} held out; the Tendon-spring fit needs at least {} "
                                "(one per parameter): record more rows{}",
                                data.source, n, n_train, held, kMinFitRows, held > 0 ? " or fit every row (--no-holdout)" : ""));
  }
  if (options.use_spgp && static_cast<std::size_t>(options.spgp.num_pseudo) > n_train) {
    throw DataError(fmt::format("{}: {} rows leave {} to fit after {} held out, fewer than the SPGP's {} pseudo-inputs; "
                                "use fewer (--pseudo-inputs), record more rows, or fit the parametric model only (--no-spgp)",
                                data.source, n, n_train, held, options.spgp.num_pseudo));
  }
  const FitResult fit = fit_tendon_spring(train, options.fit, progress.restarts);

  const FitData all{data.contraction, data.force_N, data.pressure_Pa};
  const std::vector<double> residual = pressure_residuals_Pa(fit.params, all);  // P - g^-1
  out.pressure_parametric_Pa.resize(n);
  for (std::size_t i = 0; i < n; ++i) out.pressure_parametric_Pa[i] = data.pressure_Pa[i] - residual[i];

  MuscleCalibration& c = out.calibration;
  c.muscle = options.muscle;
  c.data_file = data.source;
  c.data_sha256 = data.sha256;
  c.loadcell_zero_N = data.loadcell_zero_N;
  c.params = fit.params;
  c.contraction = span_of(data.contraction, out.heldout);
  c.force_N = span_of(data.force_N, out.heldout);
  c.pressure_Pa = span_of(data.pressure_Pa, out.heldout);
  c.residual_Pa = span_of(residual, out.heldout);
  CalibrationStats& s = c.stats;
  s.rows_train = train.pressure_Pa.size();
  s.rows_heldout = n - s.rows_train;
  s.restarts = fit.restarts_run;
  s.restarts_converged = fit.restarts_converged;
  s.lm_seconds = fit.seconds;
  s.train_rms_parametric_Pa = rms(residual, out.heldout, 0);
  s.heldout_rms_parametric_Pa = rms(residual, out.heldout, 1);

  out.pressure_spgp_Pa = out.pressure_parametric_Pa;
  out.spgp_std_Pa.assign(n, 0.0);
  std::vector<double> after = residual;
  if (options.use_spgp) {
    // Training set: the non-held-out rows, evenly thinned if there are too many.
    std::vector<std::size_t> rows;
    for (std::size_t i = 0; i < n; ++i) if (!out.heldout[i]) rows.push_back(i);
    const std::size_t stride = (rows.size() + options.max_spgp_rows - 1) / options.max_spgp_rows;
    Eigen::MatrixXd X((rows.size() + stride - 1) / stride, 2);
    Eigen::VectorXd y(X.rows());
    for (Eigen::Index r = 0; r < X.rows(); ++r) {
      const std::size_t i = rows[static_cast<std::size_t>(r) * stride];
      X(r, 0) = data.contraction[i];
      X(r, 1) = data.force_N[i];
      y[r] = residual[i];
    }
    const auto start = std::chrono::steady_clock::now();
    auto spgp = std::make_shared<const Spgp>(Spgp::fit(X, y, options.spgp, progress.spgp));
    s.spgp_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const SpgpResidual as_controller(spgp, c.contraction, c.force_N, c.residual_Pa);
    for (std::size_t i = 0; i < n; ++i) {
      const double x[2] = {data.contraction[i], data.force_N[i]};
      // As the controller evaluates it: inputs clamped to the training box, the correction to the
      // training residuals' range.
      const double mean = as_controller.pressure_Pa(x[0], x[1]);
      out.pressure_spgp_Pa[i] += mean;
      out.spgp_std_Pa[i] = std::sqrt(std::max(spgp->predict_variance(x), 0.0));
      after[i] = residual[i] - mean;
    }
    c.spgp = std::move(spgp);
  }
  s.train_rms_spgp_Pa = rms(after, out.heldout, 0);
  s.heldout_rms_spgp_Pa = rms(after, out.heldout, 1);
  return out;
}

}  // namespace peha::calibration
