/// SPGP (SPEC §2.2) benchmarks on a synthetic 2-D calibration residual, 15000 samples:
///  - BM_SpgpPredictMean: the O(M) mean the control loop calls (M = 50);
///  - BM_DenseGpPredictMean: a full GP's O(N) mean k_*^T alpha over all N = 15000 samples with the
///    same kernel, written as tightly as the SPGP's, so the two times give the speed-up in one run;
///  - BM_SpgpTrain: Spgp::fit with M = 50 on the 15000 samples, a fixed few LBFGS iterations.

#include "peha/calibration/spgp.hpp"

#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <random>

namespace peha::calibration {
namespace {

constexpr int kSamples = 15000;
constexpr int kPseudo = 50;
constexpr std::size_t kQueries = 1024;  // power of two: the index wraps with a mask
static_assert((kQueries & (kQueries - 1)) == 0);

/// A residual shaped like the calibration's (SPEC §2.3): inputs (contraction, force_N), output the
/// pressure the parametric model misses, in MPa: a smooth surface plus 3 kPa measurement noise.
struct Residual {
  Eigen::MatrixXd X;  ///< kSamples x 2: contraction [0, 0.25], force_N [0, 1500]
  Eigen::VectorXd y;  ///< residual pressure_MPa
};

double residual_MPa(double contraction, double force_N) {
  const double f = force_N / 1500.0;
  return 0.02 * std::sin(25.0 * contraction) + 0.01 * f * f - 0.06 * contraction * f;
}

const Residual& residual() {
  static const Residual data = [] {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> contraction(0.0, 0.25), force_N(0.0, 1500.0);
    std::normal_distribution<double> noise_MPa(0.0, 0.003);
    Residual r;
    r.X.resize(kSamples, 2);
    r.y.resize(kSamples);
    for (int n = 0; n < kSamples; ++n) {
      r.X(n, 0) = contraction(rng);
      r.X(n, 1) = force_N(rng);
      r.y[n] = residual_MPa(r.X(n, 0), r.X(n, 1)) + noise_MPa(rng);
    }
    return r;
  }();
  return data;
}

/// The predictor the two prediction benchmarks use (fitted once, outside any timed region).
const Spgp& trained_spgp() {
  static const Spgp model = [] {
    SpgpOptions options;
    options.num_pseudo = kPseudo;
    options.max_iterations = 100;
    return Spgp::fit(residual().X, residual().y, options);
  }();
  return model;
}

/// Query points over the data's box, in original units.
std::array<std::array<double, 2>, kQueries> queries() {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> contraction(0.0, 0.25), force_N(0.0, 1500.0);
  std::array<std::array<double, 2>, kQueries> q{};
  for (auto& x : q) x = {contraction(rng), force_N(rng)};
  return q;
}

void BM_SpgpPredictMean(benchmark::State& state) {
  const Spgp& model = trained_spgp();
  const auto q = queries();
  std::size_t k = 0;
  for (auto _ : state) {
    double mean_MPa = model.predict_mean(q[k++ & (kQueries - 1)].data());
    benchmark::DoNotOptimize(mean_MPa);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SpgpPredictMean);

void BM_SpgpPredictMeanAndVariance(benchmark::State& state) {
  const Spgp& model = trained_spgp();
  const auto q = queries();
  std::size_t k = 0;
  for (auto _ : state) {
    double variance = 0.0;
    double mean_MPa = model.predict_mean_and_variance(q[k++ & (kQueries - 1)].data(), &variance);
    benchmark::DoNotOptimize(mean_MPa);
    benchmark::DoNotOptimize(variance);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SpgpPredictMeanAndVariance);

/// A full GP's mean with the SPGP's kernel over all N training inputs: standardise x, then
/// sum_n alpha_n c exp(-1/2 sum_d b_d (x_d - x_nd)^2). The weights are stand-ins (standardised
/// targets / N): the cost does not depend on their values, and the exact (K + sigma^2 I)^-1 y at
/// N = 15000 needs a 1.8 GB matrix and ~10^12 flops, which is the point of the SPGP.
class DenseGpMean {
 public:
  explicit DenseGpMean(const Spgp& spgp)
      : mean_(spgp.input_mean()), scale_(spgp.input_scale()), b_(spgp.hyper().log_b.array().exp()),
        c_(std::exp(spgp.hyper().log_c)), output_mean_(spgp.output_mean()), output_scale_(spgp.output_scale()) {
    const Residual& r = residual();
    Xs_ = (r.X.rowwise() - mean_.transpose()).array().rowwise() / scale_.transpose().array();
    alpha_ = (r.y.array() - output_mean_) / (output_scale_ * kSamples);
  }
  double operator()(const double* x) const noexcept {
    const double x0 = (x[0] - mean_[0]) / scale_[0], x1 = (x[1] - mean_[1]) / scale_[1];
    const double* col0 = Xs_.col(0).data();
    const double* col1 = Xs_.col(1).data();
    double sum = 0.0;
    for (Eigen::Index n = 0; n < Xs_.rows(); ++n) {
      const double d0 = x0 - col0[n], d1 = x1 - col1[n];
      sum += alpha_[n] * std::exp(-0.5 * (b_[0] * d0 * d0 + b_[1] * d1 * d1));
    }
    return output_mean_ + output_scale_ * c_ * sum;
  }

 private:
  Eigen::VectorXd mean_, scale_, b_;
  double c_, output_mean_, output_scale_;
  Eigen::MatrixXd Xs_;  ///< standardised training inputs, N x 2 (columns contiguous)
  Eigen::VectorXd alpha_;
};

void BM_DenseGpPredictMean(benchmark::State& state) {
  const DenseGpMean dense(trained_spgp());
  const auto q = queries();
  std::size_t k = 0;
  for (auto _ : state) {
    double mean_MPa = dense(q[k++ & (kQueries - 1)].data());
    benchmark::DoNotOptimize(mean_MPa);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DenseGpPredictMean);

/// Training cost: 20 LBFGS iterations (each one to a few O(N M^2) NLML + gradient evaluations).
void BM_SpgpTrain(benchmark::State& state) {
  SpgpOptions options;
  options.num_pseudo = kPseudo;
  options.max_iterations = 20;
  int iterations = 0;
  for (auto _ : state) {
    const Spgp model = Spgp::fit(residual().X, residual().y, options);
    iterations = model.iterations();
    benchmark::DoNotOptimize(model.alpha().data());
  }
  state.counters["lbfgs_iterations"] = iterations;
}
BENCHMARK(BM_SpgpTrain)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace
}  // namespace peha::calibration
