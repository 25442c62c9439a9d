#pragma once
/// \file
/// Sparse Pseudo-input Gaussian Process (SPGP / FITC, Snelson & Ghahramani 2006; SPEC §2.2).
///
/// Covariance k(x, x') = c * exp(-1/2 * sum_d b_d (x_d - x'_d)^2) (+ sigma^2 on the diagonal of the
/// data). FITC: C = Q_NN + diag(K_NN - Q_NN) + sigma^2 I, Q_NN = K_NM K_MM^-1 K_MN, jitter ~1e-6 on
/// K_MM only. Hyperparameters (b_1..b_D, c, sigma^2) and the M pseudo-inputs are found by minimising
/// the negative log marginal likelihood with its analytic gradient. Works for any input dimension.
/// Inputs and outputs are standardised inside (the stored model carries the scaling).
///
/// Prediction: mean(x*) = k_*^T alpha, O(M); variance O(M^2); both allocation-free (the variance for
/// M <= kMaxStackPseudo). The M kernel values come from one vectorised pass (4 lanes, AVX2 when the
/// CPU has it) over coefficients prepared once per model.

#include <Eigen/Dense>

#include <cstdint>
#include <functional>
#include <vector>

namespace peha::calibration {

struct SpgpOptions {
  int num_pseudo = 50;        ///< M
  int max_iterations = 300;   ///< of the NLML optimiser
  std::uint64_t seed = 1;     ///< for the initial pseudo-inputs (a random subset of the data)
  double jitter = 1e-6;       ///< added to K_MM's diagonal (standardised units)
  /// Weak log-normal priors on the signal and noise variances (standardised units): log c ~
  /// N(0, 1^2), log sigma^2 ~ N(log 0.01, 2^2), i.e. MAP instead of maximum likelihood. On small
  /// data (static force maps, ~50 rows) plain FITC runs to c -> 1e5, sigma^2 -> 0 and interpolates
  /// wildly between points; on thousands of rows the prior is negligible next to the likelihood.
  bool hyper_prior = true;
};

/// Hyperparameters in standardised units, stored as logs so they stay positive.
struct SpgpHyper {
  Eigen::VectorXd log_b;   ///< ARD inverse squared length scales, one per input dimension
  double log_c = 0;        ///< signal variance
  double log_sigma2 = 0;   ///< noise variance
};

class Spgp {
 public:
  Spgp() = default;

  /// Trains on X (N x D, one row per sample) and y (N). Throws std::invalid_argument on bad shapes,
  /// non-finite data or M > N.
  static Spgp fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const SpgpOptions& options,
                  const std::function<void(int iteration, double nlml)>& progress = {});

  /// Builds a predictor from stored parts (e.g. loaded from a calibration file).
  static Spgp from_parts(const Eigen::VectorXd& input_mean, const Eigen::VectorXd& input_scale, double output_mean,
                         double output_scale, const SpgpHyper& hyper, const Eigen::MatrixXd& pseudo_inputs,
                         double jitter, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& variance_matrix);

  /// Largest M for which predict_variance and predict_mean_and_variance need no heap memory.
  static constexpr int kMaxStackPseudo = 512;

  /// Predictive mean at x (length D, original units). O(M), no allocation, noexcept.
  double predict_mean(const double* x) const noexcept;
  /// predict_mean at xa and xb into out[0] and out[1], bit for bit the same values, in one pass
  /// over the pseudo-inputs (the two kernel rows interleaved; a shared first coordinate is
  /// differenced once).
  void predict_mean_pair(const double* xa, const double* xb, double out[2]) const noexcept;
  /// Predictive variance of the latent function at x (original units^2), O(M^2).
  double predict_variance(const double* x) const;
  /// Mean and latent variance at x from one evaluation of the M kernel values (what predict_mean
  /// and predict_variance return, to round-off). No allocation for M <= kMaxStackPseudo.
  double predict_mean_and_variance(const double* x, double* variance) const;

  int input_dim() const { return static_cast<int>(input_mean_.size()); }
  int num_pseudo() const { return static_cast<int>(pseudo_.rows()); }
  const SpgpHyper& hyper() const { return hyper_; }
  const Eigen::MatrixXd& pseudo_inputs() const { return pseudo_; }   ///< standardised units, M x D
  const Eigen::VectorXd& alpha() const { return alpha_; }
  const Eigen::MatrixXd& variance_matrix() const { return var_; }    ///< K_MM^-1 - (K_MM + K_MN L^-1 K_NM)^-1
  const Eigen::VectorXd& input_mean() const { return input_mean_; }
  const Eigen::VectorXd& input_scale() const { return input_scale_; }
  double output_mean() const { return output_mean_; }
  double output_scale() const { return output_scale_; }
  double jitter() const { return jitter_; }
  /// Final objective: the NLML (standardised units), plus the hyperprior's penalty when it was on.
  double final_nlml() const { return final_nlml_; }
  int iterations() const { return iterations_; }

 private:
  Eigen::VectorXd input_mean_, input_scale_;
  double output_mean_ = 0, output_scale_ = 1;
  SpgpHyper hyper_;
  Eigen::MatrixXd pseudo_;
  double jitter_ = 1e-6;
  Eigen::VectorXd alpha_;
  Eigen::MatrixXd var_;
  double final_nlml_ = 0;
  int iterations_ = 0;

  /// Prediction coefficients, set by prepare() from the parts above: with s_d = sqrt(b_d / 2) and
  /// x'_d = (x_d - input_mean_d) s_d / input_scale_d, k_m = c exp(-sum_d (x'_d - P'_dm)^2).
  void prepare();
  int padded_pseudo_ = 0;                 ///< M rounded up to the vector width
  std::vector<double> scaled_pseudo_;     ///< P'_dm = pseudo_(m, d) s_d, row d contiguous (D x padded)
  std::vector<double> mean_weight_;       ///< output_scale c alpha_m (0 in the padding)
  std::vector<double> input_gain_;        ///< s_d / input_scale_d
};

/// FITC negative log marginal likelihood (standardised data) and its analytic gradient with
/// respect to [vec(pseudo_inputs) (M*D, column-major), log_b (D), log_c, log_sigma2]. For tests
/// and the optimiser. `gradient` may be null.
double spgp_nlml(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Eigen::MatrixXd& pseudo,
                 const SpgpHyper& hyper, double jitter, Eigen::VectorXd* gradient);

/// The same NLML from the dense N x N matrix C = Q + diag(K - Q) + sigma^2 I (O(N^3); tests only).
double spgp_nlml_dense(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Eigen::MatrixXd& pseudo,
                       const SpgpHyper& hyper, double jitter);

}  // namespace peha::calibration
