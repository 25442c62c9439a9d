/// Parametric calibration (SPEC §3.2): Ceres LM on the pressure error, best of N random restarts.
/// Synthetic data come from a known Tendon-spring model (the DMSP-40 agonist of the shipped config,
/// rounded) through models::forward_force_N, with Gaussian pressure noise of 1 kPa.

#include "peha/calibration/tendon_spring_fit.hpp"
#include "peha/models/tendon_spring.hpp"

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

// Internals of src/calibration/tendon_spring_fit.cpp exercised here (defined there with external
// linkage; the public header only carries the fit API). Solver parameters are
// x = [a, b, c (N/MPa), log(k / 1 N), eps0]; residuals are in MPa.
namespace peha::calibration::detail {
std::unique_ptr<ceres::CostFunction> make_pressure_cost_function(const FitData& data, double gain_floor_N_per_MPa);
std::unique_ptr<ceres::CostFunction> make_autodiff_pressure_cost_function(const FitData& data,
                                                                           double gain_floor_N_per_MPa);
std::array<double, 5> to_solver_params(const models::TendonSpringParams& p);
double pressure_normal_equations(const FitData& data, const std::array<double, 5>& x, std::array<double, 5>& gradient,
                                 std::array<double, 25>& jtj);
FitResult fit_tendon_spring_ceres(const FitData& data, const FitOptions& options);
std::array<double, 5> random_initial_params(std::uint64_t seed, int restart);
}  // namespace peha::calibration::detail

namespace peha::calibration {
namespace {

constexpr double kNoise_Pa = 1000.0;  // 1 kPa pressure noise

models::TendonSpringParams truth() { return peha::testing::synthetic_truth(); }

// eps uniform in [0, 0.2], P uniform in [0.1, 0.6] MPa, F = forward model, measured P = P + noise.
FitData synthetic(int n, std::uint64_t seed, double noise_Pa = kNoise_Pa) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> eps(0.0, 0.2);
  std::uniform_real_distribution<double> pressure(0.1e6, 0.6e6);
  std::normal_distribution<double> noise(0.0, noise_Pa);
  FitData d;
  for (int i = 0; i < n; ++i) {
    const double e = eps(rng);
    const double P = pressure(rng);
    d.contraction.push_back(e);
    d.force_N.push_back(models::forward_force_N(truth(), P, e));
    d.pressure_Pa.push_back(P + noise(rng));
  }
  return d;
}

double rms(const std::vector<double>& r) {
  double s = 0.0;
  for (double v : r) s += v * v;
  return std::sqrt(s / static_cast<double>(r.size()));
}

FitOptions options(int restarts, int threads, std::uint64_t seed = 1) {
  FitOptions o;
  o.restarts = restarts;
  o.threads = threads;
  o.seed = seed;
  return o;
}

// The fitted model predicts held-out pressures as well as the truth does (the noise level), and its
// inverse model matches the true one across the data's range. eps0 is exactly redundant with
// (a, b, c) (g(u + e) is again a quadratic in u), so the parameters themselves are compared through
// the identifiable quantities: the gain at each rigid-wire contraction, g(eps + eps0), and k.
TEST(TendonSpringFit, RecoversKnownModelFromNoisyData) {
  const FitData fit_data = synthetic(2000, 11);
  const FitData held_out = synthetic(2000, 12);
  const FitResult r = fit_tendon_spring(fit_data, options(30, 2));

  const double held_out_rms = rms(pressure_residuals_Pa(r.params, held_out));
  const double truth_rms = rms(pressure_residuals_Pa(truth(), held_out));
  std::printf("held-out RMS %.1f Pa (truth %.1f Pa), fit RMS %.1f Pa, k %.1f N, eps0 %.5f, converged %d/30\n",
              held_out_rms, truth_rms, r.rms_pressure_Pa, r.params.k_N, r.params.eps0, r.restarts_converged);
  EXPECT_LT(held_out_rms, 1.2 * kNoise_Pa);
  EXPECT_LT(r.rms_pressure_Pa, 1.2 * kNoise_Pa);
  EXPECT_LT(held_out_rms, 1.01 * truth_rms);

  double max_gain_error = 0.0, max_pressure_error = 0.0;
  for (double eps = 0.0; eps <= 0.2001; eps += 0.01) {
    const double g_fit = models::gain_N_per_Pa(r.params, eps + r.params.eps0);
    const double g_true = models::gain_N_per_Pa(truth(), eps + truth().eps0);
    max_gain_error = std::max(max_gain_error, std::abs(g_fit / g_true - 1.0));
    for (double P = 0.1e6; P <= 0.6e6; P += 0.05e6) {
      const double F = models::forward_force_N(truth(), P, eps);
      const models::InverseResult inv = models::inverse_pressure(r.params, F, eps, 0.8e6);
      ASSERT_EQ(inv.status, models::InverseStatus::kOk);
      max_pressure_error = std::max(max_pressure_error, std::abs(inv.pressure_Pa - P));
    }
  }
  std::printf("max gain error %.4f %%, max inverse-model error %.1f Pa, k error %.3f %%\n", 100 * max_gain_error,
              max_pressure_error, 100 * (r.params.k_N / truth().k_N - 1.0));
  EXPECT_LT(max_pressure_error, 0.3 * kNoise_Pa);
  EXPECT_LT(max_gain_error, 0.005);
  EXPECT_NEAR(r.params.k_N, truth().k_N, 0.05 * truth().k_N);
  EXPECT_EQ(r.restarts_run, 30);
  EXPECT_GT(r.restarts_converged, 0);
}

// best_cost is Ceres' 0.5 * sum r^2 with r in MPa; rms_pressure_Pa is the RMS of
// pressure_residuals_Pa at the returned parameters: the two must describe the same residual.
TEST(TendonSpringFit, ReportedCostAndRmsDescribeTheSameResidual) {
  const FitData d = synthetic(500, 21);
  const FitResult r = fit_tendon_spring(d, options(8, 2));
  const double rms_from_cost_Pa = std::sqrt(2.0 * r.best_cost / 500.0) * 1e6;
  EXPECT_NEAR(r.rms_pressure_Pa, rms_from_cost_Pa, 1e-6 * rms_from_cost_Pa);
  EXPECT_NEAR(rms(pressure_residuals_Pa(r.params, d)), r.rms_pressure_Pa, 1e-9);
  EXPECT_GT(r.seconds, 0.0);
}

// The residual is the controller's inverse model: P - models::inverse_pressure(F, eps) wherever that
// model is not clamped.
TEST(TendonSpringFit, ResidualIsThePressureErrorOfTheInverseModel) {
  const FitData d = synthetic(300, 31);
  const std::vector<double> r = pressure_residuals_Pa(truth(), d);
  ASSERT_EQ(r.size(), d.pressure_Pa.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    const models::InverseResult inv = models::inverse_pressure(truth(), d.force_N[i], d.contraction[i], 0.8e6);
    ASSERT_EQ(inv.status, models::InverseStatus::kOk);
    EXPECT_NEAR(r[i], d.pressure_Pa[i] - inv.pressure_Pa, 1e-6);  // 1 uPa
  }
}

// The best restart does not depend on how many threads ran the restarts.
TEST(TendonSpringFit, SameSeedGivesIdenticalResultWithOneOrTwoThreads) {
  const FitData d = synthetic(400, 41);
  const FitResult one = fit_tendon_spring(d, options(12, 1, 7));
  const FitResult two = fit_tendon_spring(d, options(12, 2, 7));
  EXPECT_EQ(one.params.a_N_per_Pa, two.params.a_N_per_Pa);
  EXPECT_EQ(one.params.b_N_per_Pa, two.params.b_N_per_Pa);
  EXPECT_EQ(one.params.c_N_per_Pa, two.params.c_N_per_Pa);
  EXPECT_EQ(one.params.k_N, two.params.k_N);
  EXPECT_EQ(one.params.eps0, two.params.eps0);
  EXPECT_EQ(one.best_cost, two.best_cost);
  EXPECT_EQ(one.restarts_converged, two.restarts_converged);
  // A different seed draws different starts (so the seed is really used).
  EXPECT_NE(detail::random_initial_params(7, 0), detail::random_initial_params(8, 0));
}

// Restart j's start depends only on (seed, j): 40 restarts include the 10 of a 10-restart fit.
TEST(TendonSpringFit, MoreRestartsNeverGiveAWorseBestCost) {
  const FitData d = synthetic(400, 51);
  const FitResult ten = fit_tendon_spring(d, options(10, 2, 3));
  const FitResult forty = fit_tendon_spring(d, options(40, 2, 3));
  EXPECT_LE(forty.best_cost, ten.best_cost);
  EXPECT_EQ(detail::random_initial_params(3, 9), detail::random_initial_params(3, 9));
}

// Starts are drawn inside the documented boxes.
TEST(TendonSpringFit, RandomStartsLieInTheDocumentedBoxes) {
  for (int j = 0; j < 1000; ++j) {
    const std::array<double, 5> x = detail::random_initial_params(1, j);
    EXPECT_GE(x[0], -50000.0);
    EXPECT_LE(x[0], 150000.0);
    EXPECT_GE(x[1], -100000.0);
    EXPECT_LE(x[1], 0.0);
    EXPECT_GE(x[2], 100.0);
    EXPECT_LE(x[2], 20000.0);
    EXPECT_GE(std::exp(x[3]), 1e3 * (1 - 1e-12));
    EXPECT_LE(std::exp(x[3]), 1e6 * (1 + 1e-12));
    EXPECT_GE(x[4], -0.05);
    EXPECT_LE(x[4], 0.05);
  }
}

// The starts come from std::mt19937_64 (fully specified by the standard) through a portable
// mapping, so they are the same on every platform, and tools/compare_lm_scipy.py reproduces them.
TEST(TendonSpringFit, RandomStartsArePortable) {
  const std::array<double, 5> x = detail::random_initial_params(1, 0);
  EXPECT_EQ(x[0], 38298.334889250298);
  EXPECT_EQ(x[1], -67159.771278237502);
  EXPECT_EQ(x[2], 14914.382311182215);
  EXPECT_EQ(x[3], 9.613653052603663);
  EXPECT_EQ(x[4], -0.024595440068395771);
}

TEST(TendonSpringFit, MoreThreadsThanRestartsRunsEachRestartOnce) {
  const FitData d = synthetic(200, 63);
  int calls = 0;
  const FitResult r = fit_tendon_spring(d, options(3, 8), [&](int, int) { ++calls; });
  EXPECT_EQ(calls, 3);
  EXPECT_EQ(r.restarts_run, 3);
  EXPECT_EQ(r.best_cost, fit_tendon_spring(d, options(3, 1)).best_cost);
}

TEST(TendonSpringFit, ProgressIsCalledOncePerRestartInOrder) {
  const FitData d = synthetic(200, 61);
  std::vector<int> seen;
  int reported_total = 0;
  fit_tendon_spring(d, options(9, 2), [&](int done, int total) {
    seen.push_back(done);  // serialised by the fit: no lock needed here
    reported_total = total;
  });
  ASSERT_EQ(seen.size(), 9u);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(seen[static_cast<std::size_t>(i)], i + 1);
  EXPECT_EQ(reported_total, 9);
}

// An exception thrown by the progress callback (e.g. a user cancel) reaches the caller.
TEST(TendonSpringFit, ExceptionFromProgressPropagates) {
  const FitData d = synthetic(200, 62);
  EXPECT_THROW(fit_tendon_spring(d, options(6, 2), [](int done, int) {
                 if (done == 2) throw std::runtime_error("cancelled");
               }),
               std::runtime_error);
}

TEST(TendonSpringFit, RejectsBadInput) {
  const FitData good = synthetic(50, 71);
  EXPECT_THROW(fit_tendon_spring(FitData{}, options(2, 1)), std::invalid_argument);
  FitData shorter = good;
  shorter.force_N.pop_back();
  EXPECT_THROW(fit_tendon_spring(shorter, options(2, 1)), std::invalid_argument);
  EXPECT_THROW(pressure_residuals_Pa(truth(), shorter), std::invalid_argument);
  for (std::vector<double> FitData::*column : {&FitData::contraction, &FitData::force_N, &FitData::pressure_Pa}) {
    for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
      FitData d = good;
      (d.*column)[17] = bad;
      EXPECT_THROW(fit_tendon_spring(d, options(2, 1)), std::invalid_argument);
    }
  }
  FitData four = good;  // fewer samples than parameters
  for (auto* v : {&four.contraction, &four.force_N, &four.pressure_Pa}) v->resize(4);
  EXPECT_THROW(fit_tendon_spring(four, options(2, 1)), std::invalid_argument);
  EXPECT_THROW(fit_tendon_spring(good, options(0, 1)), std::invalid_argument);
  EXPECT_THROW(fit_tendon_spring(good, options(2, 0)), std::invalid_argument);
  FitOptions no_iterations = options(2, 1);
  no_iterations.max_iterations = 0;
  EXPECT_THROW(fit_tendon_spring(good, no_iterations), std::invalid_argument);
}

// Evaluates the cost function's residuals (and optionally its Jacobian, row-major N x 5) at x.
bool evaluate(const ceres::CostFunction& cost, const std::array<double, 5>& x, std::vector<double>& residuals,
              std::vector<double>* jacobian) {
  const double* parameters[] = {x.data()};
  residuals.assign(static_cast<std::size_t>(cost.num_residuals()), 0.0);
  double* jacobians[] = {nullptr};
  if (jacobian != nullptr) {
    jacobian->assign(residuals.size() * 5, 0.0);
    jacobians[0] = jacobian->data();
  }
  return cost.Evaluate(parameters, residuals.data(), jacobian != nullptr ? jacobians : nullptr);
}

// The analytic cost the fit runs reproduces the AutoDiff reference: its residuals bit for bit those
// of the functor's double path (predicted_pressure_MPa<double>), residuals and Jacobians to
// round-off of the Jet path (which divides through a reciprocal), at the truth, at random starts, and where
// the guards are active (g below the floor, the vertex hold, k and u clamped, absurd parameters).
TEST(TendonSpringFit, AnalyticJacobianMatchesAutoDiff) {
  FitData d = synthetic(200, 83);
  d.force_N[0] = 0.0;
  const std::unique_ptr<ceres::CostFunction> analytic = detail::make_pressure_cost_function(d, 1.0);
  const std::unique_ptr<ceres::CostFunction> autodiff = detail::make_autodiff_pressure_cost_function(d, 1.0);
  std::vector<std::array<double, 5>> points = {
      detail::to_solver_params(truth()),
      {-50000.0, -100000.0, 100.0, std::log(6e4), 0.05},  // g < 0 over the whole range
      {54000.0, -48000.0, 10050.0, -800.0, 0.0},          // k -> 0 (log k clamped)
      {54000.0, -48000.0, 10050.0, 800.0, 0.0},           // k -> inf
      {1e-310, 1e5, -1e5, 0.0, 0.0},                      // vertex at -inf
      {200000.0, -20000.0, 5000.0, std::log(6e4), 0.0},   // vertex at u = 0.05: half the samples held
      {1e30, -1e30, 1e30, 1e3, 1e3},                      // absurd
  };
  for (int j = 0; j < 40; ++j) points.push_back(detail::random_initial_params(5, j));
  for (const std::array<double, 5>& x : points) {
    std::vector<double> r_analytic, J_analytic, r_autodiff, J_autodiff, r_only;
    ASSERT_TRUE(evaluate(*analytic, x, r_analytic, &J_analytic));
    ASSERT_TRUE(evaluate(*autodiff, x, r_autodiff, &J_autodiff));
    ASSERT_TRUE(evaluate(*analytic, x, r_only, nullptr));
    std::vector<double> r_double;  // AutoDiffCostFunction without Jacobians: predicted_pressure_MPa<double>
    ASSERT_TRUE(evaluate(*autodiff, x, r_double, nullptr));
    for (std::size_t i = 0; i < r_analytic.size(); ++i) {
      EXPECT_EQ(r_analytic[i], r_only[i]) << "sample " << i;
      EXPECT_EQ(r_only[i], r_double[i]) << "sample " << i;  // bit for bit (gain floor 1 N/MPa)
      EXPECT_NEAR(r_analytic[i], r_autodiff[i], 1e-12 * std::max(1.0, std::abs(r_autodiff[i]))) << "sample " << i;
      for (std::size_t p = 0; p < 5; ++p) {
        const double ad = J_autodiff[i * 5 + p];
        EXPECT_NEAR(J_analytic[i * 5 + p], ad, 1e-12 * std::max(1.0, std::abs(ad)))
            << "parameter " << p << " sample " << i << " at a=" << x[0] << " b=" << x[1] << " c=" << x[2]
            << " log k=" << x[3] << " eps0=" << x[4];
      }
    }
  }
}

// The fused pass the LM runs on (cost, J^T r, J^T J without storing J) equals the same sums formed
// from the cost function's residuals and row-major Jacobian, to round-off of the summation order.
TEST(TendonSpringFit, FusedNormalEquationsMatchTheJacobian) {
  const FitData d = synthetic(1000, 85);  // > 1 chunk of 256 samples, with a partial last one
  const std::unique_ptr<ceres::CostFunction> cost = detail::make_pressure_cost_function(d, 1.0);
  std::vector<std::array<double, 5>> points = {detail::to_solver_params(truth())};
  for (int j = 0; j < 10; ++j) points.push_back(detail::random_initial_params(11, j));
  for (const std::array<double, 5>& x : points) {
    std::vector<double> r, J;
    ASSERT_TRUE(evaluate(*cost, x, r, &J));
    double cost_ref = 0.0;
    std::array<double, 5> g_ref{};
    std::array<double, 25> h_ref{};
    for (std::size_t i = 0; i < r.size(); ++i) {
      cost_ref += 0.5 * r[i] * r[i];
      for (std::size_t p = 0; p < 5; ++p) {
        g_ref[p] += J[i * 5 + p] * r[i];
        for (std::size_t q = 0; q < 5; ++q) h_ref[p + 5 * q] += J[i * 5 + p] * J[i * 5 + q];
      }
    }
    std::array<double, 5> g{};
    std::array<double, 25> h{};
    const double c = detail::pressure_normal_equations(d, x, g, h);
    EXPECT_NEAR(c, cost_ref, 1e-12 * cost_ref);
    for (std::size_t p = 0; p < 5; ++p) {
      EXPECT_NEAR(g[p], g_ref[p], 1e-10 * std::sqrt(2.0 * cost_ref * h_ref[p * 6])) << "gradient " << p;
      for (std::size_t q = 0; q < 5; ++q) {
        EXPECT_NEAR(h[p + 5 * q], h_ref[p + 5 * q], 1e-10 * std::sqrt(h_ref[p * 6] * h_ref[q * 6]))
            << "J^T J (" << p << ", " << q << ")";
      }
    }
  }
}

// The in-house LM (5 x 5 normal equations) finds what Ceres' LM (DENSE_QR on the N x 5 Jacobian)
// finds from the same starts with the same bounds: the same best cost to 1e-7 (both stop when a step
// changes the cost by less than 1e-6 of it, so their last digits differ by path; measured 1.5e-9
// here) and, through it, the same fitted model; and about as many converged starts.
TEST(TendonSpringFit, InHouseLmFindsTheSameBestAsCeres) {
  const FitData d = synthetic(3000, 87);
  const FitOptions o = options(24, 2, 3);
  const FitResult ours = fit_tendon_spring(d, o);
  const FitResult ceres_ref = detail::fit_tendon_spring_ceres(d, o);
  EXPECT_NEAR(ours.best_cost, ceres_ref.best_cost, 1e-7 * ceres_ref.best_cost);
  EXPECT_NEAR(ours.rms_pressure_Pa, ceres_ref.rms_pressure_Pa, 1e-6 * ceres_ref.rms_pressure_Pa);
  EXPECT_NEAR(ours.params.k_N, ceres_ref.params.k_N, 1e-4 * ceres_ref.params.k_N);
  for (double eps : {0.0, 0.1, 0.2}) {
    EXPECT_NEAR(models::gain_N_per_Pa(ours.params, eps + ours.params.eps0),
                models::gain_N_per_Pa(ceres_ref.params, eps + ceres_ref.params.eps0),
                1e-5 * models::gain_N_per_Pa(ceres_ref.params, eps + ceres_ref.params.eps0))
        << "eps " << eps;
  }
  EXPECT_GE(ours.restarts_converged, ceres_ref.restarts_converged - 3);
}

// The AutoDiff Jacobian agrees with central differences at random starts (where g may be below the
// floor for some samples: the tangent continuation is C1) and at the truth.
TEST(TendonSpringFit, AutoDiffJacobianMatchesCentralDifferences) {
  const FitData d = synthetic(60, 81);
  const std::unique_ptr<ceres::CostFunction> cost = detail::make_pressure_cost_function(d, 1.0);
  ASSERT_EQ(cost->num_residuals(), 60);
  std::vector<std::array<double, 5>> points = {detail::to_solver_params(truth())};
  for (int j = 0; j < 8; ++j) points.push_back(detail::random_initial_params(99, j));
  int checked = 0;
  for (const std::array<double, 5>& x : points) {
    std::vector<double> r, J;
    ASSERT_TRUE(evaluate(*cost, x, r, &J));
    for (int p = 0; p < 5; ++p) {
      const double h = 1e-6 * std::max(std::abs(x[static_cast<std::size_t>(p)]), 1e-2);
      std::array<double, 5> lo = x, hi = x;
      lo[static_cast<std::size_t>(p)] -= h;
      hi[static_cast<std::size_t>(p)] += h;
      std::vector<double> r_lo, r_hi;
      ASSERT_TRUE(evaluate(*cost, lo, r_lo, nullptr));
      ASSERT_TRUE(evaluate(*cost, hi, r_hi, nullptr));
      for (std::size_t i = 0; i < r.size(); ++i) {
        const double numeric = (r_hi[i] - r_lo[i]) / (2.0 * h);
        const double analytic = J[i * 5 + static_cast<std::size_t>(p)];
        EXPECT_NEAR(analytic, numeric, 1e-5 * std::max(std::abs(numeric), 1e-6 / h))
            << "parameter " << p << " sample " << i << " at a=" << x[0] << " b=" << x[1] << " c=" << x[2]
            << " log k=" << x[3] << " eps0=" << x[4];
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 9 * 5 * 60);

  // Ceres' own checker (Ridders' extrapolation) agrees at the truth. Its default first step is
  // 32 x max(1e-2 |x|, 1e-2): for eps0 that crosses the vertex hold of g, so start 100x smaller.
  // No ProbeResults: its Eigen matrices are allocated inside libceres, and under ASan (the debug
  // preset) Eigen in this translation unit frees with its hand-made aligned allocator instead of
  // free() (EIGEN_MALLOC_ALREADY_ALIGNED is 0 with __SANITIZE_ADDRESS__), which ASan reports.
  ceres::NumericDiffOptions numeric_options;
  numeric_options.ridders_relative_initial_step_size = 1e-4;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(cost.get(), no_manifolds, numeric_options);
  const std::array<double, 5> x = detail::to_solver_params(truth());
  const double* parameters[] = {x.data()};
  EXPECT_TRUE(checker.Probe(parameters, 1e-6, nullptr));
}

// Where the muscle cannot pull (g <= 0), where k collapses to 0 or explodes and where the start is
// absurd, every residual and every Jacobian entry stays finite (a restart that goes there only ends
// with a bad cost), and the residual keeps growing as g falls below the floor.
TEST(TendonSpringFit, ResidualStaysFiniteWhereTheMuscleCannotPull) {
  FitData d = synthetic(40, 91);
  d.force_N[0] = 0.0;  // a sample at exactly zero force: 0 * (1/k) must not become NaN
  const std::unique_ptr<ceres::CostFunction> cost = detail::make_pressure_cost_function(d, 1.0);
  const std::vector<std::array<double, 5>> extreme = {
      {-50000.0, -100000.0, 100.0, std::log(6e4), 0.05},  // g < 0 over the whole range
      {54000.0, -48000.0, 10050.0, -800.0, 0.0},          // k -> 0: exp(800) would overflow
      {54000.0, -48000.0, 10050.0, 800.0, 0.0},           // k -> inf
      {-54000.0, -48000.0, 10050.0, -800.0, 0.0},         // k -> 0 with a < 0
      {1e-310, 1e5, -1e5, 0.0, 0.0},                      // a denormal: the vertex is at -inf
      {0.0, 0.0, 0.0, 0.0, 0.0},                          // g == 0 everywhere
      {1e30, -1e30, 1e30, 1e3, 1e3},                      // absurd
  };
  for (const std::array<double, 5>& x : extreme) {
    std::vector<double> r, J;
    ASSERT_TRUE(evaluate(*cost, x, r, &J));
    for (double v : r) EXPECT_TRUE(std::isfinite(v)) << "at a=" << x[0] << " log k=" << x[3];
    for (double v : J) EXPECT_TRUE(std::isfinite(v)) << "at a=" << x[0] << " log k=" << x[3];
  }
  // Below the floor the predicted pressure keeps rising as c falls (so LM is pushed back up).
  std::array<double, 5> x = {0.0, 0.0, 0.5, std::log(6e4), 0.0};  // g = 0.5 N/MPa < floor 1 N/MPa
  std::vector<double> r_high, r_low;
  ASSERT_TRUE(evaluate(*cost, x, r_high, nullptr));
  x[2] = -10.0;
  ASSERT_TRUE(evaluate(*cost, x, r_low, nullptr));
  for (std::size_t i = 1; i < r_high.size(); ++i) EXPECT_LT(r_low[i], r_high[i]);  // r = P - predicted

  // The fit itself survives data the model cannot describe (forces scrambled against pressures).
  FitData odd = synthetic(100, 92);
  std::reverse(odd.force_N.begin(), odd.force_N.end());
  const FitResult fr = fit_tendon_spring(odd, options(6, 2));
  EXPECT_TRUE(std::isfinite(fr.best_cost));
  EXPECT_TRUE(std::isfinite(fr.rms_pressure_Pa));
}

}  // namespace
}  // namespace peha::calibration
