/// SPGP (SPEC §2.2) benchmarks on a synthetic 2-D calibration residual, 15000 samples:
///  - BM_SpgpPredictMean: the O(M) mean the control loop calls (M = 50);
///  - BM_DenseGpPredictMean: a full GP's O(N) mean k_*^T alpha over all N = 15000 samples with the
///    same kernel, written as tightly as the SPGP's, so the two times give the speed-up in one run;
///  - BM_SpgpTrain: Spgp::fit with M = 50 on the 15000 samples, a fixed few LBFGS iterations.

#include "peha/calibration/spgp.hpp"

#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace peha::calibration {
namespace detail {
// The original one-thread FITC evaluation (src/calibration/spgp.cpp), kept as the reference.
double spgp_nlml_reference(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const Eigen::MatrixXd& pseudo,
                           const SpgpHyper& hyper, double jitter, Eigen::VectorXd* gradient);
}  // namespace detail
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

/// Training cost at the calibration's settings: M = 50 on the 15000 samples, the 300 LBFGS
/// iterations `peha calibrate` runs. Counters: iterations run, final NLML (standardised units).
void BM_SpgpTrain300(benchmark::State& state) {
  SpgpOptions options;
  options.num_pseudo = kPseudo;
  options.max_iterations = 300;
  double nlml = 0.0;
  int iterations = 0;
  for (auto _ : state) {
    const Spgp model = Spgp::fit(residual().X, residual().y, options);
    nlml = model.final_nlml();
    iterations = model.iterations();
  }
  state.counters["lbfgs_iterations"] = iterations;
  state.counters["final_nlml"] = nlml;
}
BENCHMARK(BM_SpgpTrain300)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

/// One NLML + gradient evaluation at N = 15000, M = 50 (what each LBFGS step costs), by the code
/// the fit runs and by the original one-thread evaluation (detail::spgp_nlml_reference), at the
/// same point (the model trained_spgp() ended at). Counter: relative NLML difference.
void BM_SpgpNlmlGradient(benchmark::State& state) {
  const Spgp& model = trained_spgp();
  const Residual& r = residual();
  const Eigen::MatrixXd Xs = (r.X.rowwise() - model.input_mean().transpose()).array().rowwise() /
                             model.input_scale().transpose().array();
  const Eigen::VectorXd ys = (r.y.array() - model.output_mean()) / model.output_scale();
  const bool reference = state.range(0) == 1;
  Eigen::VectorXd gradient;
  double nlml = 0.0;
  for (auto _ : state) {
    nlml = reference ? detail::spgp_nlml_reference(Xs, ys, model.pseudo_inputs(), model.hyper(), model.jitter(),
                                                   &gradient)
                     : spgp_nlml(Xs, ys, model.pseudo_inputs(), model.hyper(), model.jitter(), &gradient);
    benchmark::DoNotOptimize(gradient.data());
  }
  const double other = !reference ? detail::spgp_nlml_reference(Xs, ys, model.pseudo_inputs(), model.hyper(),
                                                                 model.jitter(), nullptr)
                                  : spgp_nlml(Xs, ys, model.pseudo_inputs(), model.hyper(), model.jitter(), nullptr);
  state.counters["nlml"] = nlml;
  state.counters["nlml_rel_diff_vs_other"] = std::abs(nlml - other) / std::abs(other);
  state.SetLabel(reference ? "original (reference)" : "as the fit runs it");
}
BENCHMARK(BM_SpgpNlmlGradient)->Arg(0)->Arg(1)->ArgName("reference")->Unit(benchmark::kMillisecond);

/// SPGP against a genuine dense GP: the data of the residual surface above, 2000 training rows and
/// 2000 held-out rows, written to $PEHA_BENCH_OUT/spgp_vs_gp/ (default out/bench) with the SPGP's
/// held-out predictions and timings; tools/compare_spgp_sklearn.py then fits sklearn's exact
/// GaussianProcessRegressor (same kernel: c RBF-ARD + white noise) on the same rows and compares.
/// 2000 rows: an exact GP with hyperparameter optimisation at that size takes about a minute here
/// (O(N^3) per likelihood evaluation); the SPGP is O(N M^2).
void BM_SpgpHeldOutVsDenseGp(benchmark::State& state) {
  constexpr int kTrain = 2000, kTest = 2000;
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> contraction(0.0, 0.25), force_N(0.0, 1500.0);
  std::normal_distribution<double> noise_MPa(0.0, 0.003);
  Eigen::MatrixXd X(kTrain + kTest, 2);
  Eigen::VectorXd y(kTrain + kTest), truth(kTrain + kTest);
  for (int n = 0; n < kTrain + kTest; ++n) {
    X(n, 0) = contraction(rng);
    X(n, 1) = force_N(rng);
    truth[n] = residual_MPa(X(n, 0), X(n, 1));
    y[n] = truth[n] + noise_MPa(rng);
  }
  SpgpOptions options;  // the calibration's: M = 50, 300 iterations
  double fit_s = 0.0, predict_ns = 0.0, rmse = 0.0, rmse_truth = 0.0;
  std::vector<double> mean(kTest), variance(kTest);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const Spgp model = Spgp::fit(X.topRows(kTrain), y.head(kTrain), options);
    const auto t1 = std::chrono::steady_clock::now();
    for (int i = 0; i < kTest; ++i) {
      const double x[2] = {X(kTrain + i, 0), X(kTrain + i, 1)};
      mean[static_cast<std::size_t>(i)] = model.predict_mean_and_variance(x, &variance[static_cast<std::size_t>(i)]);
    }
    const auto t2 = std::chrono::steady_clock::now();
    fit_s = std::chrono::duration<double>(t1 - t0).count();
    predict_ns = std::chrono::duration<double, std::nano>(t2 - t1).count() / kTest;
  }
  double sq = 0.0, sq_truth = 0.0;
  for (int i = 0; i < kTest; ++i) {
    sq += std::pow(mean[static_cast<std::size_t>(i)] - y[kTrain + i], 2);
    sq_truth += std::pow(mean[static_cast<std::size_t>(i)] - truth[kTrain + i], 2);
  }
  rmse = std::sqrt(sq / kTest);
  rmse_truth = std::sqrt(sq_truth / kTest);
  const char* env = std::getenv("PEHA_BENCH_OUT");
  const std::filesystem::path dir = std::filesystem::path(env != nullptr && *env != '\0' ? env : "out/bench") / "spgp_vs_gp";
  std::filesystem::create_directories(dir);
  std::ofstream csv(dir / "data.csv");
  csv << "set,contraction,force_N,y_MPa,truth_MPa,spgp_mean_MPa,spgp_var_MPa2\n";
  csv.precision(17);
  for (int n = 0; n < kTrain + kTest; ++n) {
    const bool test = n >= kTrain;
    csv << (test ? "test" : "train") << ',' << X(n, 0) << ',' << X(n, 1) << ',' << y[n] << ',' << truth[n] << ',';
    if (test) csv << mean[static_cast<std::size_t>(n - kTrain)] << ',' << variance[static_cast<std::size_t>(n - kTrain)];
    else csv << ',';
    csv << '\n';
  }
  std::ofstream json(dir / "spgp.json");
  json.precision(17);
  json << "{\"train_rows\": " << kTrain << ", \"test_rows\": " << kTest << ", \"num_pseudo\": " << options.num_pseudo
       << ", \"fit_seconds\": " << fit_s << ", \"predict_ns_per_point\": " << predict_ns
       << ", \"heldout_rmse_MPa\": " << rmse << ", \"heldout_rmse_vs_truth_MPa\": " << rmse_truth << "}\n";
  state.counters["fit_s"] = fit_s;
  state.counters["predict_ns"] = predict_ns;
  state.counters["heldout_rmse_kPa"] = rmse * 1e3;
  state.counters["rmse_vs_truth_kPa"] = rmse_truth * 1e3;
}
BENCHMARK(BM_SpgpHeldOutVsDenseGp)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace peha::calibration
