/// \file
/// Parametric calibration of the Tendon-spring model (SPEC §3.2): Ceres' Levenberg-Marquardt on the
/// pressure error, best of N random initialisations spread over worker threads.
///
/// Inside the solver everything is in well-conditioned units:
///   x = [a, b, c, log(k), eps0]   with a, b, c in N/MPa, k in N (log so that k > 0 and LM steps in
///                                 k are relative), eps0 dimensionless;
///   r_i = P_i - F_i / g(u_i)      in MPa, u_i = eps_i + eps0 + F_i / k, g(u) = a u^2 + b u + c.
/// g is evaluated exactly like models::gain_N_per_Pa (for a > 0, u is held at the vertex -b/(2a)),
/// so the fitted residual is the controller's inverse model minus only its output clamps. Where g
/// falls below the floor (models' min_gain_N_per_Pa = 1 N/MPa) 1/g is continued by its tangent at
/// the floor, (2 g_f - g) / g_f^2: finite, C1, and still growing as g falls, so LM is pushed back
/// towards a muscle that can pull instead of stalling on a flat plateau (no inf/NaN ever).
///
/// The cost is one residual block holding all N samples (ceres::AutoDiffCostFunction with a dynamic
/// residual count). Measured before the bounds on k and eps0 were added (15000 samples, one thread):
/// 17-21 ms per solve against 52-56 ms with one AutoDiff block per sample (Ceres' per-block
/// bookkeeping then dominates); with the bounds a solve takes ~100 ms (see `make bench`).
/// DENSE_QR on the N x 5 Jacobian: over 300 unbounded solves its linear algebra took 1.9 s of 6.8 s
/// against 0.9 s for DENSE_NORMAL_CHOLESKY, with identical results; QR is kept because the Jacobian is
/// exactly rank-deficient (below) and the normal equations square its conditioning. The AutoDiff
/// Jacobian itself is ~55% of the time (~36 ns per sample).
///
/// Note on identifiability: g is a free quadratic, and g(u + e) is again a quadratic in u, so eps0 is
/// exactly redundant with (a, b, c): g(eps + eps0) is unchanged along a line in (a, b, c, eps0),
/// and so are the vertex hold and the forward model. The fitted model (its predictions, k and the
/// gain g at each rigid-wire contraction) is well determined; the split between eps0 and (a, b, c)
/// depends on the start. LM's damping copes with the flat direction.

#include "peha/calibration/tendon_spring_fit.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace peha::calibration {

namespace detail {

/// Number of solver parameters, layout x = [a, b, c (N/MPa), log(k / 1 N), eps0].
inline constexpr int kNumSolverParams = 5;
using SolverParams = std::array<double, kNumSolverParams>;

/// Boxes of the random initialisations (uniform; k log-uniform). Physically plausible for the Festo
/// DMSP-10 ... DMSP-40 family (nominal fits: a 17000..61000, b -6300..-48400, c 740..10200 N/MPa)
/// with generous margins, and for Bowden inner wires of 1e3..1e6 N per unit contraction.
struct InitBox {
  double lo, hi;
};
inline constexpr InitBox kInitA_N_per_MPa{-50000.0, 150000.0};
inline constexpr InitBox kInitB_N_per_MPa{-100000.0, 0.0};
inline constexpr InitBox kInitC_N_per_MPa{100.0, 20000.0};
inline constexpr InitBox kInitK_N{1e3, 1e6};  // drawn uniformly in log(k)
inline constexpr InitBox kInitEps0{-0.05, 0.05};

/// Guards of the residual, so that no start and no LM trial step can produce inf/NaN (Ceres would
/// reject such a step anyway, but it dumps the whole residual block to the log). None of them is
/// active for a physical muscle; each holds its argument constant (zero derivative) beyond it.
inline constexpr double kMaxAbsLogK = 50.0;            ///< log(k / 1 N) held within +-50 before exp()
/// u held within +-1e6. A muscle lives in |u| < 0.5, but the fit's eps0 is free to drift along its
/// exactly flat direction (see the file comment) with (a, b, c) following, so any bound near 1 can be
/// reached and then bends the model for a few samples (seen with a bound at 1: SciPy's LM drifted to
/// eps0 = 0.79 from a start in +-0.05 on the benchmark data). 1e6 is far beyond any such drift; it
/// only keeps u^2 finite when k -> 0.
inline constexpr double kMaxAbsContraction = 1e6;
inline constexpr double kMaxAbsPrediction_MPa = 1e9;   ///< predicted pressure held within +-1e9 MPa

/// 1/k from the solver's log(k), with log(k) held within +-kMaxAbsLogK.
template <typename T>
T inverse_stiffness(const T& log_k) {
  using std::exp;
  if (log_k < -kMaxAbsLogK) return T(std::exp(kMaxAbsLogK));
  if (log_k > kMaxAbsLogK) return T(std::exp(-kMaxAbsLogK));
  return exp(-log_k);
}

/// Predicted pressure F / g(u) in MPa for solver parameters x (see the file comment):
///  - u = eps + eps0 + F/k, held within +-kMaxAbsContraction;
///  - the vertex hold of models::gain_N_per_Pa: for a > 0 and u past -b/(2a), u = -b/(2a) (tested as
///    2au + b > 0, which needs no division; a vertex below -kMaxAbsContraction is held there like u);
///  - g below `gain_floor` (N/MPa): 1/g continued by its tangent at the floor, (2 g_f - g) / g_f^2;
///  - the result held within +-kMaxAbsPrediction_MPa (also catches NaN).
/// `inv_k` = inverse_stiffness(x[3]), passed in so callers can hoist it out of sample loops.
template <typename T>
T predicted_pressure_MPa(const T* x, const T& inv_k, double eps, double force_N, double gain_floor) {
  const T& a = x[0];
  const T& b = x[1];
  const T& c = x[2];
  T u = eps + x[4] + force_N * inv_k;
  if (u > kMaxAbsContraction) u = T(kMaxAbsContraction);
  if (a > 0.0 && 2.0 * a * u + b > 0.0) u = -b / (2.0 * a);
  if (u < -kMaxAbsContraction) u = T(-kMaxAbsContraction);  // also a vertex at -inf (a -> 0+)
  const T g = (a * u + b) * u + c;
  T predicted = g < gain_floor ? T(force_N * (2.0 * gain_floor - g) / (gain_floor * gain_floor)) : T(force_N / g);
  if (!(predicted < kMaxAbsPrediction_MPa)) predicted = T(kMaxAbsPrediction_MPa);  // also NaN
  if (predicted < -kMaxAbsPrediction_MPa) predicted = T(-kMaxAbsPrediction_MPa);
  return predicted;
}

/// All N pressure residuals (MPa) in one block; data are held in solver units (MPa).
struct PressureErrorFunctor {
  std::vector<double> eps, force_N, pressure_MPa;
  double gain_floor_N_per_MPa = 1.0;

  template <typename T>
  bool operator()(const T* x, T* residuals) const {
    const T inv_k = inverse_stiffness(x[3]);
    const std::size_t n = eps.size();
    for (std::size_t i = 0; i < n; ++i) {
      residuals[i] = pressure_MPa[i] - predicted_pressure_MPa(x, inv_k, eps[i], force_N[i], gain_floor_N_per_MPa);
    }
    return true;
  }
};

/// Throws std::invalid_argument unless the three arrays have equal length, hold only finite values
/// and at least `min_samples` samples.
void validate(const FitData& data, std::size_t min_samples) {
  const std::size_t n = data.pressure_Pa.size();
  if (data.contraction.size() != n || data.force_N.size() != n) {
    throw std::invalid_argument("tendon_spring_fit: contraction, force_N and pressure_Pa differ in length (" +
                                std::to_string(data.contraction.size()) + ", " +
                                std::to_string(data.force_N.size()) + ", " + std::to_string(n) + ")");
  }
  if (n < min_samples) {
    throw std::invalid_argument("tendon_spring_fit: " + std::to_string(n) + " samples, at least " +
                                std::to_string(min_samples) + " needed");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(data.contraction[i]) || !std::isfinite(data.force_N[i]) || !std::isfinite(data.pressure_Pa[i])) {
      throw std::invalid_argument("tendon_spring_fit: non-finite value in sample " + std::to_string(i));
    }
  }
}

/// The cost function the fit minimises: one block, data.size() residuals in MPa, one parameter
/// block of kNumSolverParams (layout above), AutoDiff Jacobian. Owns a copy of the data.
/// `gain_floor_N_per_MPa` defaults to models::TendonSpringParams' min_gain (1e-6 N/Pa).
std::unique_ptr<ceres::CostFunction> make_pressure_cost_function(
    const FitData& data, double gain_floor_N_per_MPa = models::TendonSpringParams{}.min_gain_N_per_Pa * 1e6) {
  validate(data, 1);
  auto* functor = new PressureErrorFunctor;
  functor->eps = data.contraction;
  functor->force_N = data.force_N;
  functor->pressure_MPa.resize(data.pressure_Pa.size());
  std::transform(data.pressure_Pa.begin(), data.pressure_Pa.end(), functor->pressure_MPa.begin(),
                 [](double p) { return p * 1e-6; });
  functor->gain_floor_N_per_MPa = gain_floor_N_per_MPa;
  const int n = static_cast<int>(data.pressure_Pa.size());
  return std::make_unique<ceres::AutoDiffCostFunction<PressureErrorFunctor, ceres::DYNAMIC, kNumSolverParams>>(
      functor, n);
}

/// Model parameters -> solver parameters.
SolverParams to_solver_params(const models::TendonSpringParams& p) {
  return {p.a_N_per_Pa * 1e6, p.b_N_per_Pa * 1e6, p.c_N_per_Pa * 1e6, std::log(p.k_N), p.eps0};
}

/// Solver parameters -> model parameters (min_gain keeps its default).
models::TendonSpringParams from_solver_params(const SolverParams& x) {
  models::TendonSpringParams p;
  p.a_N_per_Pa = x[0] * 1e-6;
  p.b_N_per_Pa = x[1] * 1e-6;
  p.c_N_per_Pa = x[2] * 1e-6;
  p.k_N = std::exp(x[3]);
  p.eps0 = x[4];
  return p;
}

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix.
std::uint64_t splitmix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

/// Seed of restart j's std::mt19937_64: splitmix64(splitmix64(seed) ^ j). Independent of threads.
std::uint64_t restart_seed(std::uint64_t seed, int restart) {
  return splitmix64(splitmix64(seed) ^ static_cast<std::uint64_t>(restart));
}

/// Bounds of the fitted wire stiffness and slack (see solve_restart).
inline constexpr InitBox kFitK_N{1e3, 1e8};
inline constexpr InitBox kFitEps0{-0.05, 0.05};

/// Restart j's initial solver parameters. Draw order a, b, c, log k, eps0, each lo + (hi - lo) * U
/// with U = (engine() >> 11) * 2^-53 (portable, unlike std::uniform_real_distribution, so that
/// tools/compare_lm_scipy.py reproduces the very same starts).
SolverParams random_initial_params(std::uint64_t seed, int restart) {
  std::mt19937_64 engine(restart_seed(seed, restart));
  const auto draw = [&engine](InitBox box) {
    const double unit = static_cast<double>(engine() >> 11) * 0x1.0p-53;
    return box.lo + (box.hi - box.lo) * unit;
  };
  SolverParams x{};
  x[0] = draw(kInitA_N_per_MPa);
  x[1] = draw(kInitB_N_per_MPa);
  x[2] = draw(kInitC_N_per_MPa);
  x[3] = draw({std::log(kInitK_N.lo), std::log(kInitK_N.hi)});
  x[4] = draw(kInitEps0);
  return x;
}

/// Ceres options of one restart (single-threaded; parallelism is across restarts).
ceres::Solver::Options solver_options(int max_iterations) {
  ceres::Solver::Options o;
  o.minimizer_type = ceres::TRUST_REGION;
  o.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  o.linear_solver_type = ceres::DENSE_QR;
  o.num_threads = 1;
  o.max_num_iterations = max_iterations;
  // Ceres' default first radius (1e4, i.e. almost no damping) lets the first steps of many starts
  // jump onto the k -> 0 plateau (u held at the vertex for every sample: a constant-gain model).
  // 1e2 keeps more starts in their basin: on the 15000-sample benchmark data 201 of 300 starts reach
  // the best cost instead of 150 (SciPy's MINPACK LM: 202), for ~20% more time per solve, i.e. less
  // time per successful start.
  o.initial_trust_region_radius = 1e2;
  o.minimizer_progress_to_stdout = false;
  o.logging_type = ceres::SILENT;
  return o;
}

struct RestartOutcome {
  SolverParams x{};
  double cost = std::numeric_limits<double>::infinity();
  bool converged = false;
};

/// One LM solve from restart j's random start. A start from which the cost cannot be evaluated, or
/// a solve that ends non-finite, reports cost = +inf (it can never be the best).
RestartOutcome solve_restart(const ceres::CostFunction& cost, const ceres::Solver::Options& options,
                             std::uint64_t seed, int restart) {
  RestartOutcome out;
  out.x = random_initial_params(seed, restart);
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // Ceres' API takes a non-const pointer but only calls the const Evaluate(); with
  // DO_NOT_TAKE_OWNERSHIP the shared cost function is never deleted or mutated.
  problem.AddResidualBlock(const_cast<ceres::CostFunction*>(&cost), nullptr, out.x.data());
  // Physical bounds (Ceres projects LM steps onto them). Without them the fit drifts along the
  // exactly redundant eps0 direction and k runs off to 1e12..1e50 N when the data show no wire
  // stretch: numbers a calibration file cannot carry meaningfully. 1e8 N is a rigid wire for any
  // force below 2000 N (F/k < 2e-5 contraction).
  problem.SetParameterLowerBound(out.x.data(), 3, std::log(kFitK_N.lo));
  problem.SetParameterUpperBound(out.x.data(), 3, std::log(kFitK_N.hi));
  problem.SetParameterLowerBound(out.x.data(), 4, kFitEps0.lo);
  problem.SetParameterUpperBound(out.x.data(), 4, kFitEps0.hi);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const bool finite = std::isfinite(summary.final_cost) &&
                      std::all_of(out.x.begin(), out.x.end(), [](double v) { return std::isfinite(v); });
  out.cost = finite ? summary.final_cost : std::numeric_limits<double>::infinity();
  out.converged = finite && summary.termination_type == ceres::CONVERGENCE;
  return out;
}

}  // namespace detail

FitResult fit_tendon_spring(const FitData& data, const FitOptions& options, const Progress& progress) {
  // A fit needs at least as many samples as parameters.
  detail::validate(data, detail::kNumSolverParams);
  if (options.restarts < 1) throw std::invalid_argument("fit_tendon_spring: restarts must be >= 1");
  if (options.threads < 1) throw std::invalid_argument("fit_tendon_spring: threads must be >= 1");
  if (options.max_iterations < 1) throw std::invalid_argument("fit_tendon_spring: max_iterations must be >= 1");

  const auto start = std::chrono::steady_clock::now();
  const std::unique_ptr<ceres::CostFunction> cost = detail::make_pressure_cost_function(data);
  const ceres::Solver::Options solver_options = detail::solver_options(options.max_iterations);

  const int total = options.restarts;
  std::vector<detail::RestartOutcome> outcomes(static_cast<std::size_t>(total));
  std::atomic<int> next{0};
  std::atomic<bool> stop{false};
  std::mutex mutex;  // guards `done`, `error` and the progress callback
  int done = 0;
  std::exception_ptr error;

  const auto worker = [&] {
    while (!stop.load()) {
      const int j = next.fetch_add(1);
      if (j >= total) return;
      try {
        outcomes[static_cast<std::size_t>(j)] = detail::solve_restart(*cost, solver_options, options.seed, j);
        const std::lock_guard<std::mutex> lock(mutex);
        ++done;
        if (progress) progress(done, total);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
        stop.store(true);
        return;
      }
    }
  };
  const int num_threads = std::min(options.threads, total);
  if (num_threads == 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(static_cast<std::size_t>(num_threads));
    for (int t = 0; t < num_threads; ++t) pool.emplace_back(worker);
    for (std::thread& t : pool) t.join();
  }
  if (error) std::rethrow_exception(error);

  // Best = lowest final cost; ties go to the lower restart index (strict <), so the result does not
  // depend on which thread finished first.
  int best = -1;
  FitResult result;
  for (int j = 0; j < total; ++j) {
    const detail::RestartOutcome& o = outcomes[static_cast<std::size_t>(j)];
    if (o.converged) ++result.restarts_converged;
    if (std::isfinite(o.cost) && (best < 0 || o.cost < outcomes[static_cast<std::size_t>(best)].cost)) best = j;
  }
  if (best < 0) throw std::runtime_error("fit_tendon_spring: no restart reached a finite cost");

  const detail::RestartOutcome& winner = outcomes[static_cast<std::size_t>(best)];
  result.params = detail::from_solver_params(winner.x);
  result.best_cost = winner.cost;
  result.restarts_run = total;
  const std::vector<double> r = pressure_residuals_Pa(result.params, data);
  double sum_sq = 0.0;
  for (double v : r) sum_sq += v * v;
  result.rms_pressure_Pa = std::sqrt(sum_sq / static_cast<double>(r.size()));
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

std::vector<double> pressure_residuals_Pa(const models::TendonSpringParams& params, const FitData& data) {
  detail::validate(data, 0);
  const detail::SolverParams x = detail::to_solver_params(params);
  const double inv_k = detail::inverse_stiffness(x[3]);
  const double floor = params.min_gain_N_per_Pa * 1e6;
  std::vector<double> r(data.pressure_Pa.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    r[i] = data.pressure_Pa[i] -
           1e6 * detail::predicted_pressure_MPa(x.data(), inv_k, data.contraction[i], data.force_N[i], floor);
  }
  return r;
}

}  // namespace peha::calibration
