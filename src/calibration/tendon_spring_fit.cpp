/// \file
/// Parametric calibration of the Tendon-spring model (SPEC §3.2): Levenberg-Marquardt on the
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
/// The solver (solve_lm) is Ceres' trust-region Levenberg-Marquardt with its settings, written out
/// for this one 5-parameter problem: per iteration it needs only the 5 x 5 normal equations, which
/// one fused, vectorised pass over the samples builds (analytic Jacobian, never stored). Measured on
/// the 15000-sample benchmark data (`make bench`): Ceres with an AutoDiff cost took ~60 ms per
/// restart - 41% AutoDiff, 18% Householder QR of the 15000 x 5 Jacobian, ~30% Ceres' per-evaluation
/// bookkeeping on the 15000 residuals (array validation, copying and scaling the Jacobian); an
/// analytic Ceres cost function alone did not change that (57 ms). The fused pass takes ~2.6 ms per
/// restart. Ceres stays as the reference: the tests run the same restarts through Ceres' LM on the
/// same cost function (DENSE_QR) and compare the best cost and fitted model.
///
/// Note on identifiability: g is a free quadratic, and g(u + e) is again a quadratic in u, so eps0 is
/// exactly redundant with (a, b, c): g(eps + eps0) is unchanged along a line in (a, b, c, eps0),
/// and so are the vertex hold and the forward model. The fitted model (its predictions, k and the
/// gain g at each rigid-wire contraction) is well determined; the split between eps0 and (a, b, c)
/// depends on the start. LM's damping copes with the flat direction.

#include "peha/calibration/tendon_spring_fit.hpp"
#include "peha/calibration/dataset.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

// The 32-byte vectors below (Lanes) travel only between always-inlined helpers of this file, never
// across an ABI boundary, so GCC's note that they pass differently with and without AVX (emitted
// where the templates are instantiated, up to the end of the file) does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace peha::calibration {

namespace detail {

/// Number of solver parameters, layout x = [a, b, c (N/MPa), log(k / 1 N), eps0].
inline constexpr int kNumSolverParams = 5;
static_assert(kMinFitRows == kNumSolverParams);
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

/// All N pressure residuals (MPa) in one block, templated for ceres::AutoDiffCostFunction: the
/// reference the analytic cost below is checked against (tests), no longer what the fit runs.
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

/// The data of the fit in solver units (pressures in MPa), with the gain floor (N/MPa). The arrays
/// carry zero samples up to a multiple of kLanes, so that the kernel reads whole vectors (a zero
/// sample has r = 0 and a zero Jacobian row: F = 0, P = 0).
struct PressureData {
  std::vector<double> eps, force_N, pressure_MPa;
  std::size_t count = 0;
  double gain_floor_N_per_MPa = 1.0;
  std::size_t size() const { return count; }
};

/// What the residual of every sample shares at one x: the parameters, 1/k and the vertex hold.
struct ResidualCoefficients {
  double a, b, c, eps0, inv_k, dinv_k;  ///< dinv_k = d(1/k)/d log k (0 where log k is held)
  bool hold;                            ///< a > 0: u is held at the vertex -b/(2a) past it
  double u_vertex, du_vertex_da, du_vertex_db;
  double floor, floor_sq;               ///< gain floor g_f (N/MPa) and g_f^2
};

ResidualCoefficients residual_coefficients(const double* x, double gain_floor) {
  ResidualCoefficients k{};
  k.a = x[0];
  k.b = x[1];
  k.c = x[2];
  k.eps0 = x[4];
  k.inv_k = inverse_stiffness(x[3]);
  k.dinv_k = std::abs(x[3]) <= kMaxAbsLogK ? -k.inv_k : 0.0;
  // For a > 0, -b/(2a) and its derivatives are finite or +-inf; an infinite vertex is then held at
  // -kMaxAbsContraction, which zeroes its derivatives by selection (never inf * 0).
  k.hold = k.a > 0.0;
  k.u_vertex = k.hold ? -k.b / (2.0 * k.a) : 0.0;
  k.du_vertex_da = k.hold ? k.b / (2.0 * k.a * k.a) : 0.0;
  k.du_vertex_db = k.hold ? -1.0 / (2.0 * k.a) : 0.0;
  k.floor = gain_floor;
  k.floor_sq = gain_floor * gain_floor;
  return k;
}

/// Four doubles (GCC/Clang vector extensions: element-wise arithmetic, comparisons give 0 / -1
/// masks, `mask ? x : y` selects per lane): one AVX register, or two SSE2 registers.
inline constexpr std::size_t kLanes = 4;
using Lanes = double __attribute__((vector_size(8 * kLanes)));
using LaneMask = long long __attribute__((vector_size(8 * kLanes)));  // NOLINT(google-runtime-int): Lanes's masks

[[gnu::always_inline]] inline Lanes load_lanes(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
[[gnu::always_inline]] inline void store_lanes(double* p, Lanes v) { std::memcpy(p, &v, sizeof v); }
[[gnu::always_inline]] inline Lanes splat(double x) { return Lanes{x, x, x, x}; }

/// Residuals r[i] (MPa) of samples [0, n) and, when J is not null, the Jacobian by columns
/// (J[p * stride + i] = dr_i/dx_p). Works on kLanes samples at a time: reads inputs and writes
/// outputs up to n rounded up to a multiple of kLanes (see PressureData). Values are computed as
/// predicted_pressure_MPa<double> does, the same operations in the same order, except that the
/// tangent below the floor multiplies by 1/g_f^2 (exact for the models' floor of 1 N/MPa): the
/// residuals are bit-identical to it (tested); the Jacobian is the chain rule through the same guards, each guard holding
/// its argument constant (zero derivative) where it is active:
///   du/dx = [0, 0, 0, F d(1/k)/dlog k, 1];  at the vertex hold du/dx = [b/(2a^2), -1/(2a), 0, 0, 0]
///   dg/dx = [u^2, u, 1, 0, 0] + (2 a u + b) du/dx
///   dpred/dg = -F/g^2, or -F/g_f^2 on the tangent below the floor;  dr/dx = -dpred/dg dg/dx.
/// Branch-free: both sides of every guard are computed and a select picks one. Written with vector
/// extensions because GCC does not vectorise the scalar form (a division under a condition is not
/// if-converted with -ftrapping-math, and the Jacobian loop not at all).
/// The core of residual_kernel on kLanes samples: their residuals (MPa), and their Jacobian rows by
/// parameter (J[p]) when kJacobian. Always inlined, so the AVX2 clones below get AVX2 code.
struct LaneKernel {
  Lanes a, b, c, eps0, inv_k, two_a, two_f, f, inv_f2, u_vertex, zero, max_u, min_u, max_p, min_p;
  Lanes du_vertex_da, du_vertex_db, dinv_k;
  LaneMask hold;

  explicit LaneKernel(const ResidualCoefficients& k)
      : a(splat(k.a)), b(splat(k.b)), c(splat(k.c)), eps0(splat(k.eps0)), inv_k(splat(k.inv_k)),
        two_a(splat(2.0 * k.a)), two_f(splat(2.0 * k.floor)), f(splat(k.floor)), inv_f2(splat(1.0 / k.floor_sq)),
        u_vertex(splat(k.u_vertex)), zero(splat(0.0)), max_u(splat(kMaxAbsContraction)),
        min_u(splat(-kMaxAbsContraction)), max_p(splat(kMaxAbsPrediction_MPa)), min_p(splat(-kMaxAbsPrediction_MPa)),
        du_vertex_da(splat(k.du_vertex_da)), du_vertex_db(splat(k.du_vertex_db)), dinv_k(splat(k.dinv_k)),
        hold(k.hold ? LaneMask{-1, -1, -1, -1} : LaneMask{0, 0, 0, 0}) {}

  template <bool kJacobian>
  [[gnu::always_inline]] Lanes operator()(Lanes eps, Lanes F, Lanes pressure, Lanes* J) const {
    const Lanes u_raw = eps + eps0 + F * inv_k;
    const LaneMask high = u_raw > max_u;
    const Lanes u_clamped = high ? max_u : u_raw;
    const LaneMask past = hold & (two_a * u_clamped + b > zero);
    const Lanes u_held = past ? u_vertex : u_clamped;
    const LaneMask low = u_held < min_u;
    const Lanes u = low ? min_u : u_held;
    const Lanes g = (a * u + b) * u + c;
    const LaneMask below = g < f;
    const Lanes quotient = F / g;
    const Lanes predicted_raw = below ? F * (two_f - g) * inv_f2 : quotient;
    const LaneMask capped_high = ~(predicted_raw < max_p);  // also NaN
    const LaneMask capped_low = predicted_raw < min_p;
    const Lanes predicted = capped_high ? max_p : (capped_low ? min_p : predicted_raw);
    if constexpr (kJacobian) {
      // Which guard u went through: free (u = u_raw: derivatives in log k and eps0), the vertex
      // hold (derivatives in a and b), or a clamp (constant).
      const LaneMask free = ~high & ~past & ~low;
      const LaneMask vertex = past & ~low;
      const Lanes slope = two_a * u + b;  // dg/du
      const Lanes dr_dg = (capped_high | capped_low) ? zero : (below ? F * inv_f2 : quotient / g);  // -dpred/dg
      const Lanes u2 = u * u;
      J[0] = dr_dg * (vertex ? u2 + slope * du_vertex_da : u2);
      J[1] = dr_dg * (vertex ? u + slope * du_vertex_db : u);
      J[2] = dr_dg;
      J[3] = free ? dr_dg * (slope * (F * dinv_k)) : zero;
      J[4] = free ? dr_dg * slope : zero;
    }
    return pressure - predicted;
  }
};

void residual_kernel(const ResidualCoefficients& k, const double* eps, const double* force, const double* pressure,
                     std::size_t n, double* r, double* J, std::size_t stride) {
  const LaneKernel kernel(k);
  for (std::size_t i = 0; i < n; i += kLanes) {
    if (J == nullptr) {
      store_lanes(r + i, kernel.operator()<false>(load_lanes(eps + i), load_lanes(force + i), load_lanes(pressure + i),
                                                 nullptr));
      continue;
    }
    Lanes row[kNumSolverParams];
    store_lanes(r + i, kernel.operator()<true>(load_lanes(eps + i), load_lanes(force + i), load_lanes(pressure + i), row));
    for (std::size_t p = 0; p < static_cast<std::size_t>(kNumSolverParams); ++p) store_lanes(J + p * stride + i, row[p]);
  }
}

/// Samples per chunk of the fused evaluations below: a 256 x 6 block stays in L1.
inline constexpr std::size_t kChunk = 256;

/// The same N residuals with their analytic Jacobian as a Ceres cost function (residual_kernel;
/// Ceres wants the Jacobian row-major). The reference Ceres solve in the tests runs on it.
class PressureErrorCost final : public ceres::CostFunction {
 public:
  explicit PressureErrorCost(PressureData data) : data_(std::move(data)) {
    set_num_residuals(static_cast<int>(data_.size()));
    mutable_parameter_block_sizes()->push_back(kNumSolverParams);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const ResidualCoefficients k = residual_coefficients(parameters[0], data_.gain_floor_N_per_MPa);
    const std::size_t n = data_.size();
    double* J = jacobians != nullptr ? jacobians[0] : nullptr;
    std::array<double, kChunk> r;
    std::array<double, kNumSolverParams * kChunk> columns;
    for (std::size_t i0 = 0; i0 < n; i0 += kChunk) {
      const std::size_t len = std::min(kChunk, n - i0);
      residual_kernel(k, data_.eps.data() + i0, data_.force_N.data() + i0, data_.pressure_MPa.data() + i0, len,
                      r.data(), J != nullptr ? columns.data() : nullptr, kChunk);
      std::copy_n(r.begin(), len, residuals + i0);
      if (J == nullptr) continue;
      for (std::size_t i = 0; i < len; ++i)
        for (std::size_t p = 0; p < static_cast<std::size_t>(kNumSolverParams); ++p)
          J[(i0 + i) * kNumSolverParams + p] = columns[p * kChunk + i];
    }
    return true;
  }

 private:
  PressureData data_;
};

/// 0.5 sum r^2 (MPa^2) at x: Ceres' cost, summed in a fixed order (per lane, lanes added at the end).
/// Built twice, for AVX2 and for any x86-64, picked at load time (GCC target_clones); without
/// -ffp-contract both give the same bits.
[[gnu::target_clones("avx2", "default")]] double pressure_cost(const PressureData& d, const double* x) {
  const LaneKernel kernel(residual_coefficients(x, d.gain_floor_N_per_MPa));
  Lanes sum = splat(0.0);
  for (std::size_t i = 0; i < d.size(); i += kLanes) {
    const Lanes r = kernel.operator()<false>(load_lanes(d.eps.data() + i), load_lanes(d.force_N.data() + i),
                                            load_lanes(d.pressure_MPa.data() + i), nullptr);
    sum += r * r;
  }
  return 0.5 * ((sum[0] + sum[1]) + (sum[2] + sum[3]));
}

using Vector5 = Eigen::Matrix<double, kNumSolverParams, 1>;
using Matrix5 = Eigen::Matrix<double, kNumSolverParams, kNumSolverParams>;

/// The Gauss-Newton quantities at x, fused in one pass over the data: cost 0.5 |r|^2, gradient
/// J^T r and J^T J, without ever storing the N x 5 Jacobian.
struct NormalEquations {
  double cost = 0;
  Vector5 gradient = Vector5::Zero();
  Matrix5 jtj = Matrix5::Zero();
};

/// One pass: the kernel's residuals and Jacobian rows go straight into 21 accumulators (one per
/// lane) of [J | r]^T [J | r] (the 6 x 6 upper triangle); the lanes are added at the end. Nothing
/// of size N is stored. AVX2 and generic builds as pressure_cost.
[[gnu::target_clones("avx2", "default")]] NormalEquations pressure_normal_equations(const PressureData& d, const double* x) {
  const LaneKernel kernel(residual_coefficients(x, d.gain_floor_N_per_MPa));
  constexpr int kCols = kNumSolverParams + 1;
  Lanes acc[kCols * (kCols + 1) / 2] = {};
  const std::size_t n = d.size();
  for (std::size_t i = 0; i < n; i += kLanes) {
    Lanes v[kCols];
    v[kNumSolverParams] = kernel.operator()<true>(load_lanes(d.eps.data() + i), load_lanes(d.force_N.data() + i),
                                                  load_lanes(d.pressure_MPa.data() + i), v);
    int e = 0;
    for (int p = 0; p < kCols; ++p)
      for (int q = p; q < kCols; ++q) acc[e++] += v[p] * v[q];
  }
  NormalEquations ne;
  int e = 0;
  for (int p = 0; p < kCols; ++p) {
    for (int q = p; q < kCols; ++q, ++e) {
      const double sum = (acc[e][0] + acc[e][1]) + (acc[e][2] + acc[e][3]);
      if (p < kNumSolverParams && q < kNumSolverParams) {
        ne.jtj(p, q) = sum;
        ne.jtj(q, p) = sum;
      } else if (p < kNumSolverParams) {
        ne.gradient[p] = sum;
      } else {
        ne.cost = 0.5 * sum;
      }
    }
  }
  return ne;
}

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

/// The fit's data in solver units. Throws like validate().
PressureData pressure_data(const FitData& data, double gain_floor_N_per_MPa) {
  validate(data, 1);
  PressureData d;
  d.count = data.pressure_Pa.size();
  d.eps = data.contraction;
  d.force_N = data.force_N;
  d.pressure_MPa.resize(d.count);
  std::transform(data.pressure_Pa.begin(), data.pressure_Pa.end(), d.pressure_MPa.begin(),
                 [](double p) { return p * 1e-6; });
  const std::size_t padded = (d.count + kLanes - 1) / kLanes * kLanes;  // zero samples the kernel may read
  d.eps.resize(padded, 0.0);
  d.force_N.resize(padded, 0.0);
  d.pressure_MPa.resize(padded, 0.0);
  d.gain_floor_N_per_MPa = gain_floor_N_per_MPa;
  return d;
}

/// models::TendonSpringParams' min_gain (1e-6 N/Pa) in N/MPa.
inline const double kDefaultGainFloor_N_per_MPa = models::TendonSpringParams{}.min_gain_N_per_Pa * 1e6;

/// The residuals as a Ceres cost function: one block, data.size() residuals in MPa, one parameter
/// block of kNumSolverParams (layout above), analytic Jacobian. Owns a copy of the data.
std::unique_ptr<ceres::CostFunction> make_pressure_cost_function(const FitData& data,
                                                                 double gain_floor_N_per_MPa = kDefaultGainFloor_N_per_MPa) {
  return std::make_unique<PressureErrorCost>(pressure_data(data, gain_floor_N_per_MPa));
}

/// The same residuals with an AutoDiff Jacobian (PressureErrorFunctor): the reference for tests.
std::unique_ptr<ceres::CostFunction> make_autodiff_pressure_cost_function(const FitData& data,
                                                                           double gain_floor_N_per_MPa) {
  PressureData d = pressure_data(data, gain_floor_N_per_MPa);
  auto* functor = new PressureErrorFunctor;
  d.eps.resize(d.count);
  d.force_N.resize(d.count);
  d.pressure_MPa.resize(d.count);
  functor->eps = std::move(d.eps);
  functor->force_N = std::move(d.force_N);
  functor->pressure_MPa = std::move(d.pressure_MPa);
  functor->gain_floor_N_per_MPa = gain_floor_N_per_MPa;
  const int n = static_cast<int>(data.pressure_Pa.size());
  return std::make_unique<ceres::AutoDiffCostFunction<PressureErrorFunctor, ceres::DYNAMIC, kNumSolverParams>>(
      functor, n);
}

/// Cost, gradient and J^T J at x on `data` (for tests: the fused pass against the cost function).
double pressure_normal_equations(const FitData& data, const std::array<double, kNumSolverParams>& x,
                                 std::array<double, kNumSolverParams>& gradient,
                                 std::array<double, kNumSolverParams * kNumSolverParams>& jtj) {
  const NormalEquations ne = pressure_normal_equations(pressure_data(data, kDefaultGainFloor_N_per_MPa), x.data());
  Eigen::Map<Vector5>(gradient.data()) = ne.gradient;
  Eigen::Map<Matrix5>(jtj.data()) = ne.jtj;
  return ne.cost;
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

/// Levenberg-Marquardt settings. They are Ceres' (trust-region LM with Jacobi scaling, see
/// ceres::Solver::Options) so the in-house solver and the Ceres reference behave alike:
/// - Ceres' default first radius (1e4, i.e. almost no damping) lets the first steps of many starts
///   jump onto the k -> 0 plateau (u held at the vertex for every sample: a constant-gain model).
///   1e2 keeps more starts in their basin: on the 15000-sample benchmark data 201 of 300 starts reach
///   the best cost instead of 150 (SciPy's MINPACK LM: 202).
struct LmSettings {
  int max_iterations = 200;
  double initial_radius = 1e2;
  double max_radius = 1e16;
  double min_radius = 1e-32;
  double min_lm_diagonal = 1e-6;
  double max_lm_diagonal = 1e32;
  double min_relative_decrease = 1e-3;
  double function_tolerance = 1e-6;
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-8;
  int max_consecutive_invalid_steps = 5;
};

/// Ceres options of the reference solve (single-threaded; parallelism is across restarts).
ceres::Solver::Options ceres_solver_options(const LmSettings& lm) {
  ceres::Solver::Options o;
  o.minimizer_type = ceres::TRUST_REGION;
  o.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  o.linear_solver_type = ceres::DENSE_QR;
  o.num_threads = 1;
  o.max_num_iterations = lm.max_iterations;
  o.initial_trust_region_radius = lm.initial_radius;
  o.minimizer_progress_to_stdout = false;
  o.logging_type = ceres::SILENT;
  return o;
}

struct RestartOutcome {
  SolverParams x{};
  double cost = std::numeric_limits<double>::infinity();
  bool converged = false;
};

/// Physical bounds of the solver parameters (log k and eps0; a, b, c are free). Without them the
/// fit drifts along the exactly redundant eps0 direction and k runs off to 1e12..1e50 N when the
/// data show no wire stretch: numbers a calibration file cannot carry meaningfully. 1e8 N is a rigid
/// wire for any force below 2000 N (F/k < 2e-5 contraction).
Vector5 lower_bounds() {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  return (Vector5() << -kInf, -kInf, -kInf, std::log(kFitK_N.lo), kFitEps0.lo).finished();
}
Vector5 upper_bounds() {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  return (Vector5() << kInf, kInf, kInf, std::log(kFitK_N.hi), kFitEps0.hi).finished();
}

/// One LM solve from x0: Ceres' trust-region Levenberg-Marquardt (levenberg_marquardt_strategy,
/// trust_region_minimizer) on the 5 x 5 normal equations, which the fused pass builds without the
/// N x 5 Jacobian:
///  - Jacobi scaling fixed at the start, s_p = 1 / (1 + |J_p|), the step solved in scaled variables;
///  - step: (S J^T J S + diag(clamp(diag(S J^T J S), 1e-6, 1e32)) / radius) z = -S J^T r, delta = S z;
///  - the bounds: a parameter on a bound whose descent points outwards is held for the step (active
///    set), the others' x + delta projected onto the box (as Ceres' bounded parameter blocks); the
///    model decrease -(g.d + 1/2 d^T J^T J d) is that of the projected step d;
///  - accepted when (actual / model decrease) > 1e-3; then radius /= max(1/3, 1 - (2 rho - 1)^3),
///    else radius /= 2, 4, 8, ...;
///  - converged as Ceres: |step| <= 1e-8 (|x| + 1e-8), |cost change| <= 1e-6 cost, or the projected
///    gradient's max norm <= 1e-10.
/// The normal equations square the conditioning of J (which is exactly rank-deficient along the
/// eps0 direction, see the file comment); the damping keeps the 5 x 5 system positive definite, a
/// failed factorisation counts as an invalid step (smaller radius), as in Ceres.
RestartOutcome solve_lm(const PressureData& d, const LmSettings& lm, const SolverParams& x0) {
  RestartOutcome out;
  const Vector5 lo = lower_bounds(), hi = upper_bounds();
  Vector5 x = Eigen::Map<const Vector5>(x0.data()).cwiseMax(lo).cwiseMin(hi);
  NormalEquations ne = pressure_normal_equations(d, x.data());
  if (!std::isfinite(ne.cost) || !ne.gradient.allFinite() || !ne.jtj.allFinite()) return out;
  const Vector5 scale = (1.0 + ne.jtj.diagonal().array().sqrt()).inverse().matrix();
  const auto projected_gradient_norm = [&](const Vector5& at, const Vector5& gradient) {
    return (at - (at - gradient).cwiseMax(lo).cwiseMin(hi)).lpNorm<Eigen::Infinity>();
  };
  double radius = lm.initial_radius;
  double decrease_factor = 2.0;
  int invalid_steps = 0;
  bool converged = projected_gradient_norm(x, ne.gradient) <= lm.gradient_tolerance;
  for (int iteration = 0; iteration < lm.max_iterations && !converged; ++iteration) {
    const Matrix5 scaled = scale.asDiagonal() * ne.jtj * scale.asDiagonal();
    Matrix5 damped = scaled;
    damped.diagonal() +=
        (scaled.diagonal().cwiseMax(lm.min_lm_diagonal).cwiseMin(lm.max_lm_diagonal) / radius).eval();
    // Active bounds: a parameter on its bound whose descent direction points out of the box is held
    // (its row and column replaced by the identity, its step 0), so the step of the others is not
    // spoilt by a projection after the fact.
    Vector5 rhs = -scale.cwiseProduct(ne.gradient);
    for (int p = 0; p < kNumSolverParams; ++p) {
      if ((x[p] <= lo[p] && rhs[p] < 0.0) || (x[p] >= hi[p] && rhs[p] > 0.0)) {
        damped.row(p).setZero();
        damped.col(p).setZero();
        damped(p, p) = 1.0;
        rhs[p] = 0.0;
      }
    }
    const Eigen::LLT<Matrix5> llt(damped);
    Vector5 candidate = x;
    double model_decrease = 0.0;
    if (llt.info() == Eigen::Success) {
      const Vector5 delta = scale.cwiseProduct(llt.solve(rhs));
      candidate = (x + delta).cwiseMax(lo).cwiseMin(hi);
      const Vector5 step = candidate - x;
      model_decrease = -(ne.gradient.dot(step) + 0.5 * step.dot(ne.jtj * step));
    }
    if (!(model_decrease > 0.0) || !candidate.allFinite()) {
      // Invalid step (failed factorisation, no model decrease): shrink the region as Ceres does.
      if (++invalid_steps > lm.max_consecutive_invalid_steps) break;
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < lm.min_radius) {
        converged = true;
        break;
      }
      continue;
    }
    invalid_steps = 0;
    if ((candidate - x).norm() <= lm.parameter_tolerance * (x.norm() + lm.parameter_tolerance)) {
      converged = true;
      break;
    }
    double candidate_cost = pressure_cost(d, candidate.data());
    if (!std::isfinite(candidate_cost)) candidate_cost = std::numeric_limits<double>::max();
    const double cost_change = ne.cost - candidate_cost;
    if (std::abs(cost_change) <= lm.function_tolerance * ne.cost) {
      converged = true;
      break;
    }
    const double rho = cost_change / model_decrease;
    if (rho > lm.min_relative_decrease) {
      NormalEquations next = pressure_normal_equations(d, candidate.data());
      if (!std::isfinite(next.cost) || !next.gradient.allFinite() || !next.jtj.allFinite()) break;
      x = candidate;
      ne = next;
      const double t = 2.0 * rho - 1.0;
      radius = std::min(lm.max_radius, radius / std::max(1.0 / 3.0, 1.0 - t * t * t));
      decrease_factor = 2.0;
      converged = projected_gradient_norm(x, ne.gradient) <= lm.gradient_tolerance;
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < lm.min_radius) converged = true;
    }
  }
  Eigen::Map<Vector5>(out.x.data()) = x;
  out.cost = std::isfinite(ne.cost) && x.allFinite() ? ne.cost : std::numeric_limits<double>::infinity();
  out.converged = converged && std::isfinite(out.cost);
  return out;
}

/// The same solve by Ceres (DENSE_QR on the N x 5 Jacobian of PressureErrorCost, the bounds as
/// parameter bounds): the reference the tests compare solve_lm with.
RestartOutcome solve_ceres(const ceres::CostFunction& cost, const LmSettings& lm, const SolverParams& x0) {
  RestartOutcome out;
  out.x = x0;
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  // Ceres' API takes a non-const pointer but only calls the const Evaluate(); with
  // DO_NOT_TAKE_OWNERSHIP the shared cost function is never deleted or mutated.
  problem.AddResidualBlock(const_cast<ceres::CostFunction*>(&cost), nullptr, out.x.data());
  problem.SetParameterLowerBound(out.x.data(), 3, std::log(kFitK_N.lo));
  problem.SetParameterUpperBound(out.x.data(), 3, std::log(kFitK_N.hi));
  problem.SetParameterLowerBound(out.x.data(), 4, kFitEps0.lo);
  problem.SetParameterUpperBound(out.x.data(), 4, kFitEps0.hi);
  ceres::Solver::Summary summary;
  ceres::Solve(ceres_solver_options(lm), &problem, &summary);
  const bool finite = std::isfinite(summary.final_cost) &&
                      std::all_of(out.x.begin(), out.x.end(), [](double v) { return std::isfinite(v); });
  out.cost = finite ? summary.final_cost : std::numeric_limits<double>::infinity();
  out.converged = finite && summary.termination_type == ceres::CONVERGENCE;
  return out;
}

/// Runs `solve(j)` for j = 0 .. restarts-1 on `threads` workers (each restart on one thread; which
/// thread runs which restart does not matter, the outcome of restart j depends on j alone) and
/// keeps the best: lowest final cost, ties to the lower restart index.
template <typename Solve>
FitResult run_restarts(const FitData& data, const FitOptions& options, const Progress& progress, Solve&& solve) {
  const auto start = std::chrono::steady_clock::now();
  const int total = options.restarts;
  std::vector<RestartOutcome> outcomes(static_cast<std::size_t>(total));
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
        outcomes[static_cast<std::size_t>(j)] = solve(j);
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
    const RestartOutcome& o = outcomes[static_cast<std::size_t>(j)];
    if (o.converged) ++result.restarts_converged;
    if (std::isfinite(o.cost) && (best < 0 || o.cost < outcomes[static_cast<std::size_t>(best)].cost)) best = j;
  }
  if (best < 0) throw DataError("fit_tendon_spring: no restart reached a finite cost (data no Tendon-spring model fits)");

  const RestartOutcome& winner = outcomes[static_cast<std::size_t>(best)];
  result.params = from_solver_params(winner.x);
  result.best_cost = winner.cost;
  result.restarts_run = total;
  const std::vector<double> r = pressure_residuals_Pa(result.params, data);
  double sum_sq = 0.0;
  for (double v : r) sum_sq += v * v;
  result.rms_pressure_Pa = std::sqrt(sum_sq / static_cast<double>(r.size()));
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void validate_options(const FitData& data, const FitOptions& options) {
  // A fit needs at least as many samples as parameters.
  validate(data, kNumSolverParams);
  if (options.restarts < 1) throw std::invalid_argument("fit_tendon_spring: restarts must be >= 1");
  if (options.threads < 1) throw std::invalid_argument("fit_tendon_spring: threads must be >= 1");
  if (options.max_iterations < 1) throw std::invalid_argument("fit_tendon_spring: max_iterations must be >= 1");
}

/// The fit with every restart solved by Ceres instead of solve_lm (tests and the benchmark's
/// before/after; same starts, same bounds, same best-of rule).
FitResult fit_tendon_spring_ceres(const FitData& data, const FitOptions& options) {
  validate_options(data, options);
  const std::unique_ptr<ceres::CostFunction> cost = make_pressure_cost_function(data);
  LmSettings lm;
  lm.max_iterations = options.max_iterations;
  return run_restarts(data, options, {}, [&](int j) {
    return solve_ceres(*cost, lm, random_initial_params(options.seed, j));
  });
}

}  // namespace detail

FitResult fit_tendon_spring(const FitData& data, const FitOptions& options, const Progress& progress) {
  detail::validate_options(data, options);
  const detail::PressureData d = detail::pressure_data(data, detail::kDefaultGainFloor_N_per_MPa);
  detail::LmSettings lm;
  lm.max_iterations = options.max_iterations;
  return detail::run_restarts(data, options, progress, [&](int j) {
    return detail::solve_lm(d, lm, detail::random_initial_params(options.seed, j));
  });
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
