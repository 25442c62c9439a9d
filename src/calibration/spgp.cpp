#include "peha/calibration/spgp.hpp"

#include <ceres/first_order_function.h>
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

namespace peha::calibration {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

/// Largest input dimension a model may have: predict_mean standardises x into a stack buffer of
/// this size so that it never allocates. fit() and from_parts() reject anything wider.
constexpr int kMaxInputDim = 16;

/// Log-parameters are kept inside this box during the line search: exp(+-30) is already far
/// outside any sensible standardised length scale or variance, and exp() must not overflow.
constexpr double kMaxAbsLogHyper = 30.0;

/// Bad user input: always std::invalid_argument, prefixed so the caller sees where it came from.
[[noreturn]] void reject(const std::string& what) { throw std::invalid_argument("Spgp: " + what); }

/// "rows x cols", for error messages.
std::string shape(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + " x " + std::to_string(cols);
}

/// K(i, j) = c * exp(-1/2 * sum_d b_d (A(i, d) - B(j, d))^2), for all rows of A and B, into K
/// (resized only if its shape changes; r2 is scratch of A.rows()).
void ard_kernel(const MatrixXd& A, const MatrixXd& B, const VectorXd& b, double c, MatrixXd& K, Eigen::ArrayXd& r2) {
  K.resize(A.rows(), B.rows());
  r2.resize(A.rows());
  for (Eigen::Index j = 0; j < B.rows(); ++j) {
    r2.setZero();
    for (Eigen::Index d = 0; d < A.cols(); ++d) r2 += b[d] * (A.col(d).array() - B(j, d)).square();
    K.col(j) = c * (-0.5 * r2).exp();
  }
}

/// The same kernel matrix, freshly allocated (for the dense reference).
MatrixXd ard_kernel(const MatrixXd& A, const MatrixXd& B, const VectorXd& b, double c) {
  MatrixXd K;
  Eigen::ArrayXd r2;
  ard_kernel(A, B, b, c, K, r2);
  return K;
}

/// Shapes spgp_nlml and spgp_nlml_dense need: X N x D, y N, pseudo M x D (M >= 1), log_b D.
void check_problem_shapes(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper) {
  if (X.rows() != y.size()) reject("X has " + std::to_string(X.rows()) + " rows but y has " + std::to_string(y.size()));
  if (pseudo.cols() != X.cols())
    reject("pseudo-inputs are " + shape(pseudo.rows(), pseudo.cols()) + ", expected M x " + std::to_string(X.cols()));
  if (hyper.log_b.size() != X.cols())
    reject("log_b has " + std::to_string(hyper.log_b.size()) + " entries, expected " + std::to_string(X.cols()));
  if (pseudo.rows() < 1) reject("no pseudo-inputs");
}

/// What one FITC evaluation may hand back besides the NLML (each optional).
struct FitcRequest {
  VectorXd* gradient = nullptr;         ///< [vec(pseudo), log_b, log_c, log_sigma2]
  VectorXd* alpha = nullptr;            ///< A^-1 K_MN Lambda^-1 y: mean(x*) = k_*^T alpha
  MatrixXd* variance_matrix = nullptr;  ///< K_MM^-1 - A^-1
};

/// The samples in blocks of kBlock (fitc_evaluate), and what its forward pass leaves for the gradient pass.
struct FitcBlocks {
  std::vector<double> X;              ///< [block][d][kBlock]: inputs, 0 in the padding
  std::vector<double> y;              ///< [block * kBlock + q]: y_n, 0 in the padding
  std::vector<double> valid;          ///< [block * kBlock + q]: 1 for a sample, 0 for padding
  std::vector<double> K;              ///< [block][m][kBlock]: K_NM, 0 in the padding
  std::vector<double> V;              ///< [block][m][kBlock]: V = L^-1 K_MN
  std::vector<double> lambda;         ///< [block * kBlock + q]: Lambda_n
  std::vector<double> y_over_lambda;  ///< [block * kBlock + q]
};

/// Doubles per per-lane accumulator entry of the blocked passes (Lanes below).
constexpr int kLanes = 4;

/// Per-lane sums of one half's gradient pass (four lanes per entry, added at the end).
struct GradientSums {
  std::vector<double> Va;              ///< M: V a
  std::vector<double> VwV;             ///< packed lower M x M: V diag(w) V^T
  std::vector<double> q_sum, r_sum;    ///< M: sum_n E'(n, m), sum_n K(n, m) a_n
  std::vector<double> q_lin, r_lin;    ///< M x D (m + d M): the same times (x_nd - p_md)
  std::vector<double> q_sq, r_sq;      ///< M x D: times (x_nd - p_md)^2
  std::vector<double> w_sum;           ///< 1
  void reset(int M, int D) {
    const auto m = static_cast<std::size_t>(M) * kLanes, md = m * static_cast<std::size_t>(D);
    Va.assign(m, 0.0);
    VwV.assign(static_cast<std::size_t>(M) * (M + 1) / 2 * kLanes, 0.0);
    q_sum.assign(m, 0.0);
    r_sum.assign(m, 0.0);
    q_lin.assign(md, 0.0);
    r_lin.assign(md, 0.0);
    q_sq.assign(md, 0.0);
    r_sq.assign(md, 0.0);
    w_sum.assign(kLanes, 0.0);
  }
};

/// A second thread for the halves of the blocked passes (for_two_halves), started on first use and
/// kept until the workspace goes: the optimiser's workspace lives for the whole fit, so one thread
/// serves all its evaluations instead of one new thread per pass (two per evaluation).
class HalfWorker {
 public:
  HalfWorker() = default;
  HalfWorker(const HalfWorker&) = delete;
  HalfWorker& operator=(const HalfWorker&) = delete;
  ~HalfWorker() {
    if (!thread_.joinable()) return;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
  }

  /// Runs job() on the worker thread (starting it if need be); wait() returns when it is done.
  void start(const std::function<void()>& job) {
    if (!thread_.joinable()) thread_ = std::thread([this] { loop(); });
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      job_ = &job;
      done_ = false;
      error_ = nullptr;
    }
    wake_.notify_one();
  }
  /// Waits for the job start() handed over; rethrows what it threw.
  void wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    finished_.wait(lock, [this] { return done_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || job_ != nullptr; });
      if (stop_) return;
      const std::function<void()>* job = std::exchange(job_, nullptr);
      lock.unlock();
      std::exception_ptr error;
      try {
        (*job)();
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      error_ = error;
      done_ = true;
      finished_.notify_one();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, finished_;
  const std::function<void()>* job_ = nullptr;
  bool done_ = false, stop_ = false;
  std::exception_ptr error_;
  std::thread thread_;
};

/// Scratch of one FITC evaluation. The optimiser keeps one alive across evaluations so the N x M
/// matrices (6 MB each at N = 15000, M = 50) are not reallocated and page-faulted every time, nor
/// the per-half accumulators, and one second thread serves all evaluations.
struct FitcWorkspace {
  MatrixXd Kmm_kernel, Kmm, Knm, V, U, B, R, Z, G, E;
  Eigen::ArrayXd r2;
  FitcBlocks blocks;
  std::vector<double> scratch[2];  ///< per half: kMaxGroup x M x kBlock doubles for the passes (U, then W)
  std::vector<double> B_acc[2], Vy_acc[2];  ///< per half: the forward pass's sums
  GradientSums sums[2];                     ///< per half: the gradient pass's sums
  HalfWorker worker;                        ///< declared last: its thread stops before the rest goes
};

/// The kernel's scales, exp of the log-hypers.
struct KernelScales {
  VectorXd b;     ///< ARD inverse squared length scales
  double c;       ///< signal variance
  double sigma2;  ///< noise variance
};

/// The scales of `hyper`, and K_MM into ws: Kmm_kernel without jitter (what the hypers move), Kmm with it.
KernelScales scales_and_kmm(const MatrixXd& pseudo, const SpgpHyper& hyper, double jitter, FitcWorkspace& ws) {
  KernelScales k{hyper.log_b.array().exp().matrix(), std::exp(hyper.log_c), std::exp(hyper.log_sigma2)};
  ard_kernel(pseudo, pseudo, k.b, k.c, ws.Kmm_kernel, ws.r2);
  ws.Kmm = ws.Kmm_kernel;
  ws.Kmm.diagonal().array() += jitter;
  return k;
}

/// The end both evaluations share, from B = I + U U^T's factor and beta = L_B^-1 V Lambda^-1 y: the
/// NLML (non-finite: the caller returns inf), gamma = B^-1 V Lambda^-1 y, and alpha and the
/// predictive variance matrix when `request` asks for them.
template <class LowerFactor, class UpperFactor>
double nlml_and_outputs(const Eigen::LLT<MatrixXd>& llt_b, const VectorXd& beta, const VectorXd& y,
                        const VectorXd& y_over_lambda, const VectorXd& lambda, const LowerFactor& L, const UpperFactor& Lt,
                        const FitcRequest& request, VectorXd& gamma) {
  const Eigen::Index N = y.size(), M = beta.size();
  const double quad = y.dot(y_over_lambda) - beta.squaredNorm();
  const double log_det =
      lambda.array().log().sum() + 2.0 * llt_b.matrixLLT().diagonal().array().log().sum();
  const double nlml = 0.5 * (log_det + quad + static_cast<double>(N) * std::log(2.0 * std::numbers::pi));
  if (!std::isfinite(nlml)) return nlml;

  gamma = llt_b.matrixU().solve(beta);  // B^-1 V Lambda^-1 y
  if (request.alpha != nullptr) *request.alpha = Lt.solve(gamma);
  if (request.variance_matrix != nullptr) {
    const MatrixXd L_inv = L.solve(MatrixXd::Identity(M, M));
    const MatrixXd I_minus_B_inv = MatrixXd::Identity(M, M) - llt_b.solve(MatrixXd::Identity(M, M));
    MatrixXd var = L_inv.transpose() * I_minus_B_inv * L_inv;
    *request.variance_matrix = 0.5 * (var + var.transpose());  // symmetric up to round-off
  }
  return nlml;
}

/// The FITC NLML as first written (one thread, S = Z V^T by a full product): the reference the
/// tests hold fitc_evaluate to (spgp_nlml_reference). Otherwise unchanged. Returns +inf when K_MM,
/// Lambda or B is not positive definite (numerically). Notation and the gradient's derivation: at
/// fitc_evaluate, which computes the same formulas in another order.
double fitc_evaluate_reference(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper,
                     double jitter, const FitcRequest& request, FitcWorkspace& ws) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::Index N = X.rows(), M = pseudo.rows(), D = X.cols();
  const auto [b, c, sigma2] = scales_and_kmm(pseudo, hyper, jitter, ws);
  ard_kernel(X, pseudo, b, c, ws.Knm, ws.r2);
  const MatrixXd& Knm = ws.Knm;

  const Eigen::LLT<MatrixXd> llt_mm(ws.Kmm);
  if (llt_mm.info() != Eigen::Success) return kInf;
  const auto L = llt_mm.matrixL();
  const auto Lt = llt_mm.matrixU();
  MatrixXd& V = ws.V;  // M x N
  V = Knm.transpose();
  L.solveInPlace(V);

  const VectorXd lambda = (c + sigma2) - V.colwise().squaredNorm().transpose().array();
  if (!(lambda.minCoeff() > 0.0)) return kInf;
  const VectorXd inv_sqrt_lambda = lambda.cwiseSqrt().cwiseInverse();

  MatrixXd& U = ws.U;
  U.noalias() = V * inv_sqrt_lambda.asDiagonal();
  MatrixXd& B = ws.B;
  B.setIdentity(M, M);
  B.selfadjointView<Eigen::Lower>().rankUpdate(U);
  const Eigen::LLT<MatrixXd> llt_b(B);  // reads the lower triangle only
  if (llt_b.info() != Eigen::Success) return kInf;

  const VectorXd y_over_lambda = y.cwiseQuotient(lambda);
  const VectorXd beta = llt_b.matrixL().solve(V * y_over_lambda);
  VectorXd gamma;
  const double nlml = nlml_and_outputs(llt_b, beta, y, y_over_lambda, lambda, L, Lt, request, gamma);
  if (!std::isfinite(nlml)) return kInf;
  if (request.gradient == nullptr) return nlml;

  MatrixXd& R = ws.R;  // B^-1 U
  R = U;
  llt_b.solveInPlace(R);
  const VectorXd a = (y - V.transpose() * gamma).cwiseQuotient(lambda);  // C^-1 y
  const VectorXd Va = V * a;
  VectorXd w(N);
  MatrixXd& Z = ws.Z;
  Z.resize(M, N);
  for (Eigen::Index n = 0; n < N; ++n) {
    const double c_inv_nn = (1.0 - U.col(n).dot(R.col(n))) / lambda[n];
    w[n] = c_inv_nn - a[n] * a[n];
    Z.col(n) = inv_sqrt_lambda[n] * R.col(n) - w[n] * V.col(n) - a[n] * Va;
  }
  MatrixXd& G = ws.G;
  G = Z;
  Lt.solveInPlace(G);
  const MatrixXd S = Z * V.transpose();
  const MatrixXd T = Lt.solve(S);                    // L^-T S
  MatrixXd H = Lt.solve(T.transpose()).transpose();  // L^-T S L^-1
  H = 0.5 * (H + H.transpose());

  MatrixXd& E = ws.E;  // dNLML/dK_NM .* K_NM, N x M
  E.noalias() = Knm.cwiseProduct(G.transpose());
  const MatrixXd F = H.cwiseProduct(ws.Kmm_kernel);  // dK_MM's coefficient (x -2) .* K_MM

  VectorXd& grad = *request.gradient;
  grad.setZero(M * D + D + 2);
  const double w_sum = w.sum();
  for (Eigen::Index d = 0; d < D; ++d) {
    double data_sq = 0.0, pseudo_sq = 0.0;
    for (Eigen::Index m = 0; m < M; ++m) {
      const double xb = pseudo(m, d);
      double data_lin = 0.0;
      for (Eigen::Index n = 0; n < N; ++n) {
        const double diff = X(n, d) - xb;
        const double t = E(n, m) * diff;
        data_lin += t;
        data_sq += t * diff;
      }
      double pseudo_lin = 0.0;
      for (Eigen::Index k = 0; k < M; ++k) {
        const double diff = xb - pseudo(k, d);
        pseudo_lin += F(m, k) * diff;
        pseudo_sq += F(m, k) * diff * diff;
      }
      grad[d * M + m] = b[d] * (data_lin + pseudo_lin);
    }
    grad[M * D + d] = -0.5 * b[d] * data_sq + 0.25 * b[d] * pseudo_sq;
  }
  grad[M * D + D] = E.sum() - 0.5 * F.sum() + 0.5 * c * w_sum;
  grad[M * D + D + 1] = 0.5 * sigma2 * w_sum;
  return nlml;
}

// The 32- and 64-byte vectors below (Lanes, Lanes8) travel only between always-inlined helpers of this
// file, never across an ABI boundary, so GCC's note that they pass differently with and without AVX
// (AVX-512) does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

/// Four doubles (GCC/Clang vector extensions): one AVX register, or two SSE2 registers.
using Lanes = double __attribute__((vector_size(8 * kLanes)));
using LaneBits = long long __attribute__((vector_size(8 * kLanes)));  // NOLINT(google-runtime-int)

/// A vector of doubles of type V (Lanes, or Lanes8 in the AVX-512 passes) from memory, to memory, broadcast.
template <class V>
[[gnu::always_inline]] inline V vload(const double* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class V>
[[gnu::always_inline]] inline void vstore(double* p, const V& v) { std::memcpy(p, &v, sizeof v); }
template <class V>
[[gnu::always_inline]] inline V vsplat(double x) {
  if constexpr (sizeof(V) == 4 * sizeof(double)) {
    return V{x, x, x, x};
  } else {
    // Not V{x, x, ...}: GCC 12 builds that lane by lane with masked broadcasts; this is one vbroadcastsd.
    static_assert(sizeof(V) == 8 * sizeof(double));
    V v = {};
    v[0] = x;
    return __builtin_shufflevector(v, v, 0, 0, 0, 0, 0, 0, 0, 0);
  }
}
[[gnu::always_inline]] inline Lanes load_lanes(const double* p) { return vload<Lanes>(p); }
[[gnu::always_inline]] inline Lanes splat(double x) { return vsplat<Lanes>(x); }

/// exp(x) for x <= 0, per lane (x < -708 gives 0; exp(-708) = 3e-308 is no weight anyway).
/// Cody-Waite reduction x = n ln2 + r, |r| <= ln2 / 2, a polynomial for exp(r) (below) and 2^n from
/// the exponent bits (tests: the predictor against std::exp-based formulas to 1e-13). Same operations in every clone
/// and vector width (no FMA; spgp.cpp is compiled with -ffp-contract=off), so the same bits on every x86-64.
template <class V>
[[gnu::always_inline]] inline V exp_nonpositive(const V& x) {
  using Bits = decltype(x < x);  // 64-bit integer lanes
  const V clamped = x < vsplat<V>(-708.0) ? vsplat<V>(-708.0) : x;
  const V shifter = vsplat<V>(0x1.8p52);  // adding it rounds to an integer in the low mantissa bits
  const V t = clamped * vsplat<V>(1.4426950408889634) + shifter;
  const V n = t - shifter;
  const V r = (clamped - n * vsplat<V>(6.93147180369123816490e-01)) - n * vsplat<V>(1.90821492927058770002e-10);
  // exp(r) on [-ln2/2, ln2/2] by a degree-10 Chebyshev fit (mpmath.chebyfit at 40 digits, rounded
  // to double: 4.4e-16 relative at worst in double arithmetic, i.e. 2 ulp), evaluated by Estrin's
  // scheme: 4 dependent multiply-add levels instead of Horner's 10 (the pass is latency-bound).
  const V r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const V q0 = vsplat<V>(1.0) + vsplat<V>(1.0000000000000067) * r;
  const V q1 = vsplat<V>(0.5000000000000006) + vsplat<V>(0.16666666666554406) * r;
  const V q2 = vsplat<V>(0.04166666666657314) + vsplat<V>(0.008333333385667782) * r;
  const V q3 = vsplat<V>(0.0013888888932488599) + vsplat<V>(0.00019841170270440067) * r;
  const V q4 = vsplat<V>(2.4801504346997686e-05) + vsplat<V>(2.764018079620985e-06) * r;
  const V q5 = vsplat<V>(2.7626357241447223e-07);
  const V p = (q0 + q1 * r2 + (q2 + q3 * r2) * r4) + (q4 + q5 * r2) * r8;
  Bits t_bits, shifter_bits;
  std::memcpy(&t_bits, &t, sizeof t);
  std::memcpy(&shifter_bits, &shifter, sizeof shifter);
  const Bits s_bits = (t_bits - shifter_bits + 1023) << 52;  // n in [-1022, 0]: a normal 2^n
  V scale;
  std::memcpy(&scale, &s_bits, sizeof scale);
  const V result = p * scale;
  return x < vsplat<V>(-708.0) ? vsplat<V>(0.0) : result;
}

/// Runs body(begin, end, half) over [0, n) in two halves, the second half on `worker`'s thread (the
/// calibration machine has two cores and nothing else to do during a fit). n < min_split runs inline.
template <typename Body>
void for_two_halves(Eigen::Index n, Eigen::Index min_split, HalfWorker& worker, Body&& body) {
  if (n < min_split) {
    body(Eigen::Index{0}, n, 0);
    return;
  }
  const Eigen::Index mid = n / 2;
  const std::function<void()> second = [&] { body(mid, n, 1); };
  worker.start(second);
  try {
    body(Eigen::Index{0}, mid, 0);
  } catch (...) {
    worker.wait();  // the second half still uses the caller's data
    throw;
  }
  worker.wait();
}

// The per-sample work of fitc_evaluate runs on blocks of kBlock samples, four Lanes side by side:
// each per-sample vector of length M (a row of K_NM, a column of V, ...) is stored M x kBlock, so
// the M x M factors enter as broadcast scalars and every operation is lane-wise over samples (sums
// over samples stay in per-lane accumulators until the end). The substitutions with the two Cholesky
// factors and the symmetric rank updates are the O(N M^2) part: 4 x 4 independent lanes per step.
//
// The passes are written for a vector type V of kW = 4 (Lanes: AVX2 / SSE2) or 8 doubles (Lanes8:
// AVX-512), kBlock / kW vectors per row of a block. Lane-wise work does not depend on kW. Every sum
// that combines the four 4-lane groups of a block (s = 0..3: samples 4 s .. 4 s + 3) goes through
// tree4 or seq4 below, which take the groups in the same order for both widths: both give the same
// bits, and with them the same bits as each other's clones.
constexpr int kBlockVecs = 4;
constexpr int kBlock = kLanes * kBlockVecs;
constexpr Eigen::Index kMinSplitBlocks = 2000 / kBlock;  // below this a thread costs more than it saves

[[gnu::always_inline]] inline void store_lanes(double* p, const Lanes& v) { vstore(p, v); }
template <class V>
[[gnu::always_inline]] inline V lane_sqrt(const V& v) {
  V r;
  for (int i = 0; i < static_cast<int>(sizeof(V) / sizeof(double)); ++i) r[i] = std::sqrt(v[i]);
  return r;
}
/// acc[0..3] += v (an accumulator of four lanes in memory).
[[gnu::always_inline]] inline void accumulate(double* acc, const Lanes& v) { store_lanes(acc, load_lanes(acc) + v); }
/// (v[0] + v[1]) + (v[2] + v[3]) of four lanes in memory.
inline double lane_sum(const double* v) { return (v[0] + v[1]) + (v[2] + v[3]); }

/// The four 4-lane groups s = 0..3 of one block row held as kBlock / kW vectors of type V.
template <class V>
[[gnu::always_inline]] inline void lane_groups(const V* p, Lanes q[kBlockVecs]) {
  if constexpr (sizeof(V) == sizeof(Lanes)) {
    for (int s = 0; s < kBlockVecs; ++s) q[s] = p[s];
  } else {
    static_assert(sizeof(V) == 2 * sizeof(Lanes) && kBlockVecs == 4);
    q[0] = __builtin_shufflevector(p[0], p[0], 0, 1, 2, 3);
    q[1] = __builtin_shufflevector(p[0], p[0], 4, 5, 6, 7);
    q[2] = __builtin_shufflevector(p[1], p[1], 0, 1, 2, 3);
    q[3] = __builtin_shufflevector(p[1], p[1], 4, 5, 6, 7);
  }
}
/// (q0 + q1) + (q2 + q3) of a block row's four groups.
template <class V>
[[gnu::always_inline]] inline Lanes tree4(const V* p) {
  Lanes q[kBlockVecs];
  lane_groups(p, q);
  return (q[0] + q[1]) + (q[2] + q[3]);
}
/// (((0 + q0) + q1) + q2) + q3 of a block row's four groups.
template <class V>
[[gnu::always_inline]] inline Lanes seq4(const V* p) {
  Lanes q[kBlockVecs];
  lane_groups(p, q);
  Lanes sum = splat(0.0);
  for (int s = 0; s < kBlockVecs; ++s) sum += q[s];
  return sum;
}

/// What the forward pass reads besides the blocks.
struct ForwardArgs {
  int M, D;
  const double* pseudo;      ///< M x D, column-major
  const double* b;           ///< D
  double c, c_plus_sigma2;
  const double* L_rows;      ///< L (L L^T = K_MM) row-major: L(i, j) at i M + j
  const double* L_inv_diag;  ///< 1 / L(i, i)
};

/// Blocks a pass handles side by side: kMaxGroup in the AVX-512 build (twice the independent
/// vectors in the substitutions, which 32 vector registers hold), 1 for the 4-double builds.
constexpr int kMaxGroup = 2;

/// Forward pass over the P blocks blk0 .. blk0 + P - 1, side by side: K_NM, V = L^-1 K_MN, Lambda,
/// y / Lambda into `fb`; adds U U^T (packed lower triangle, four lanes per entry) to B_acc and
/// V Lambda^-1 y (four lanes per entry) to Vy_acc, block after block, so each accumulator gets the
/// same sums in the same order whatever P. U is scratch of P M kBlock doubles. Vector t of a row
/// (t < P kT) is vector t % kT of block t / kT.
template <class V, int P>
[[gnu::always_inline]] inline void forward_group(const ForwardArgs& a, FitcBlocks& fb, Eigen::Index blk0,
                                                 double* B_acc, double* Vy_acc, double* U) {
  constexpr int kW = sizeof(V) / sizeof(double), kT = kBlock / kW, kG = P * kT;
  const int M = a.M, D = a.D;
  const std::size_t per_block = static_cast<std::size_t>(M) * kBlock;
  const double* x[P];
  const double* valid[P];
  double *K[P], *Vb[P], *Ub[P];
  std::size_t at0[P];
  for (int p = 0; p < P; ++p) {
    const auto ub = static_cast<std::size_t>(blk0 + p);
    x[p] = fb.X.data() + ub * static_cast<std::size_t>(D) * kBlock;
    valid[p] = fb.valid.data() + ub * kBlock;
    K[p] = fb.K.data() + ub * per_block;
    Vb[p] = fb.V.data() + ub * per_block;
    Ub[p] = U + static_cast<std::size_t>(p) * per_block;
    at0[p] = ub * kBlock;
  }
  // Offset of vector t (of block t / kT) in row i of an M x kBlock block.
  constexpr auto off = [](int i, int t) { return i * kBlock + (t % kT) * kW; };
  // K(n, m) = c exp(-1/2 sum_d b_d (x_nd - p_md)^2), as ard_kernel.
  for (int m = 0; m < M; ++m) {
    for (int t = 0; t < kG; ++t) {
      V r2 = vsplat<V>(0.0);
      for (int d = 0; d < D; ++d) {
        const V diff = vload<V>(x[t / kT] + off(d, t)) - a.pseudo[d * M + m];
        r2 += a.b[d] * (diff * diff);
      }
      vstore(K[t / kT] + off(m, t), a.c * exp_nonpositive(vsplat<V>(-0.5) * r2) * vload<V>(valid[t / kT] + off(0, t)));
    }
  }
  // V = L^-1 K by forward substitution.
  for (int i = 0; i < M; ++i) {
    const double* row = a.L_rows + static_cast<std::size_t>(i) * M;
    V acc[kG];
    for (int t = 0; t < kG; ++t) acc[t] = vload<V>(K[t / kT] + off(i, t));
    for (int j = 0; j < i; ++j) {
      const double l = row[j];  // scalar times vector: one broadcast, also in the AVX-512 build
      for (int t = 0; t < kG; ++t) acc[t] -= l * vload<V>(Vb[t / kT] + off(j, t));
    }
    const double inv = a.L_inv_diag[i];
    for (int t = 0; t < kG; ++t) vstore(Vb[t / kT] + off(i, t), acc[t] * inv);
  }
  // Lambda = c + sigma^2 - |V_n|^2, U = V Lambda^-1/2, y / Lambda.
  V sq[kG], y_over_lambda[kG], inv_sqrt[kG];
  for (int t = 0; t < kG; ++t) sq[t] = vsplat<V>(0.0);
  for (int i = 0; i < M; ++i) {
    for (int t = 0; t < kG; ++t) {
      const V v = vload<V>(Vb[t / kT] + off(i, t));
      sq[t] += v * v;
    }
  }
  for (int t = 0; t < kG; ++t) {
    const V lambda = vsplat<V>(a.c_plus_sigma2) - sq[t];
    const std::size_t at = at0[t / kT] + static_cast<std::size_t>(t % kT) * kW;
    vstore(fb.lambda.data() + at, lambda);
    y_over_lambda[t] = vload<V>(fb.y.data() + at) / lambda;
    vstore(fb.y_over_lambda.data() + at, y_over_lambda[t]);
    inv_sqrt[t] = vsplat<V>(1.0) / lane_sqrt(lambda);
  }
  for (int i = 0; i < M; ++i)
    for (int t = 0; t < kG; ++t) vstore(Ub[t / kT] + off(i, t), vload<V>(Vb[t / kT] + off(i, t)) * inv_sqrt[t]);
  // B += U U^T (lower), Vy += V Lambda^-1 y, block after block.
  for (int i = 0; i < M; ++i) {
    V ui[kG];
    for (int t = 0; t < kG; ++t) ui[t] = vload<V>(Ub[t / kT] + off(i, t));
    double* row = B_acc + static_cast<std::size_t>(i) * (i + 1) / 2 * kLanes;
    for (int j = 0; j <= i; ++j) {
      V prod[kG];
      for (int t = 0; t < kG; ++t) prod[t] = ui[t] * vload<V>(Ub[t / kT] + off(j, t));
      for (int p = 0; p < P; ++p) accumulate(row + j * kLanes, tree4(prod + p * kT));
    }
    V vy[kG];
    for (int t = 0; t < kG; ++t) vy[t] = vload<V>(Vb[t / kT] + off(i, t)) * y_over_lambda[t];
    for (int p = 0; p < P; ++p) accumulate(Vy_acc + i * kLanes, seq4(vy + p * kT));
  }
}

/// Forward pass over blocks [b0, b1), P blocks at a time (forward_group).
template <class V, int P>
[[gnu::always_inline]] inline void forward_blocks(const ForwardArgs& a, FitcBlocks& fb, Eigen::Index b0,
                                                  Eigen::Index b1, double* B_acc, double* Vy_acc, double* U) {
  static_assert(P >= 1 && P <= kMaxGroup);
  Eigen::Index blk = b0;
  for (; blk + P <= b1; blk += P) forward_group<V, P>(a, fb, blk, B_acc, Vy_acc, U);
  if constexpr (P > 1)
    for (; blk < b1; ++blk) forward_group<V, 1>(a, fb, blk, B_acc, Vy_acc, U);
}
static_assert(kBlockVecs == 4, "fitc_forward_blocks and fitc_gradient_blocks write the four Lanes of a block out");

/// What the gradient pass reads besides the blocks.
struct GradientArgs {
  int M, D;
  const double* pseudo;       ///< M x D, column-major
  const double* gamma;        ///< B^-1 V Lambda^-1 y
  const double* LB_rows;      ///< L_B (L_B L_B^T = B) row-major
  const double* LB_cols;      ///< L_B column-major: L_B(j, i) at i M + j
  const double* LB_inv_diag;
  const double* L_cols;       ///< L column-major
  const double* L_inv_diag;
};

/// The P blocks of one gradient_group, which its steps below share. Vector t of a row (t < kG) is
/// vector t % kT of block blk0 + t / kT.
template <class V, int P>
struct GradientGroup {
  static constexpr int kW = sizeof(V) / sizeof(double), kT = kBlock / kW, kG = P * kT;
  const double *x[P], *K[P], *Vb[P];
  double* Wb[P];  ///< t = L_B^-1 u, then r = B^-1 u, then G'
  std::size_t at0[P];
  /// Offset of vector t in row i of an M x kBlock block.
  static constexpr int off(int i, int t) { return i * kBlock + (t % kT) * kW; }
  /// Index of vector t's first sample in the per-sample arrays of FitcBlocks.
  std::size_t at(int t) const { return at0[t / kT] + static_cast<std::size_t>(t % kT) * kW; }
};

/// The blocks' rows in `fb` and their scratch in W (P M kBlock doubles).
template <class V, int P>
[[gnu::always_inline]] inline void gradient_group_blocks(const GradientArgs& a, const FitcBlocks& fb, Eigen::Index blk0,
                                                         double* W, GradientGroup<V, P>& g) noexcept {
  const std::size_t per_block = static_cast<std::size_t>(a.M) * kBlock;
  for (int p = 0; p < P; ++p) {
    const auto ub = static_cast<std::size_t>(blk0 + p);
    g.x[p] = fb.X.data() + ub * static_cast<std::size_t>(a.D) * kBlock;
    g.K[p] = fb.K.data() + ub * per_block;
    g.Vb[p] = fb.V.data() + ub * per_block;
    g.Wb[p] = W + static_cast<std::size_t>(p) * per_block;
    g.at0[p] = ub * kBlock;
  }
}

/// Lambda, Lambda^-1/2 and a = (y - V^T gamma) / Lambda.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_a(const GradientArgs& a, const FitcBlocks& fb, const GradientGroup<V, P>& g,
                                              V* lambda, V* inv_sqrt, V* av) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M;
  V dot[kG];
  for (int t = 0; t < kG; ++t) {
    lambda[t] = vload<V>(fb.lambda.data() + g.at(t));
    inv_sqrt[t] = vsplat<V>(1.0) / lane_sqrt(lambda[t]);
    dot[t] = vsplat<V>(0.0);
  }
  for (int i = 0; i < M; ++i) {
    const double gi = a.gamma[i];
    for (int t = 0; t < kG; ++t) dot[t] += vload<V>(g.Vb[t / kT] + g.off(i, t)) * gi;
  }
  for (int t = 0; t < kG; ++t) av[t] = (vload<V>(fb.y.data() + g.at(t)) - dot[t]) / lambda[t];
}

/// Row i of a substitution in place in W: acc -= l_j W_j for j in [j0, j1), then W_i = acc / L(i, i)
/// (inv_diag[i] = 1 / L(i, i)).
template <class V, int P>
[[gnu::always_inline]] inline void substitute_row(const GradientGroup<V, P>& g, const double* l, int j0, int j1, int i,
                                                  const double* inv_diag, V* acc) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  for (int j = j0; j < j1; ++j) {
    const double lj = l[j];  // scalar times vector: one broadcast, also in the AVX-512 build
    for (int t = 0; t < kG; ++t) acc[t] -= lj * vload<V>(g.Wb[t / kT] + g.off(j, t));
  }
  const double inv = inv_diag[i];
  for (int t = 0; t < kG; ++t) vstore(g.Wb[t / kT] + g.off(i, t), acc[t] * inv);
}

/// Adds V a to sums.Va; t = L_B^-1 u into W by forward substitution (u = V Lambda^-1/2).
template <class V, int P>
[[gnu::always_inline]] inline void gradient_va_and_t(const GradientArgs& a, const GradientGroup<V, P>& g, const V* av,
                                                     const V* inv_sqrt, GradientSums& sums) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M;
  for (int i = 0; i < M; ++i) {
    V va[kG];
    for (int t = 0; t < kG; ++t) va[t] = av[t] * vload<V>(g.Vb[t / kT] + g.off(i, t));
    for (int p = 0; p < P; ++p) accumulate(sums.Va.data() + i * kLanes, seq4(va + p * kT));
    V acc[kG];
    for (int t = 0; t < kG; ++t) acc[t] = vload<V>(g.Vb[t / kT] + g.off(i, t)) * inv_sqrt[t];
    substitute_row(g, a.LB_rows + static_cast<std::size_t>(i) * M, 0, i, i, a.LB_inv_diag, acc);
  }
}

/// w = diag(C^-1) - a^2 with diag(C^-1)_n = (1 - u_n^T B^-1 u_n) / Lambda_n = (1 - |t_n|^2) / Lambda_n
/// (0 in the padding); adds it to sums.w_sum.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_w(const GradientArgs& a, const FitcBlocks& fb, const GradientGroup<V, P>& g,
                                              const V* lambda, const V* av, V* w, GradientSums& sums) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M;
  V tt[kG];
  for (int t = 0; t < kG; ++t) tt[t] = vsplat<V>(0.0);
  for (int i = 0; i < M; ++i) {
    for (int t = 0; t < kG; ++t) {
      const V v = vload<V>(g.Wb[t / kT] + g.off(i, t));
      tt[t] += v * v;
    }
  }
  for (int t = 0; t < kG; ++t) {
    const V c_inv_nn = (vsplat<V>(1.0) - tt[t]) / lambda[t];
    w[t] = (c_inv_nn - av[t] * av[t]) * vload<V>(fb.valid.data() + g.at(t));
  }
  for (int p = 0; p < P; ++p) accumulate(sums.w_sum.data(), seq4(w + p * kT));
}

/// r = L_B^-T t, then G' = L^-T (r Lambda^-1/2 - w v), both by back substitution in place in W.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_g_prime(const GradientArgs& a, const GradientGroup<V, P>& g,
                                                    const V* inv_sqrt, const V* w) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M;
  for (int i = M - 1; i >= 0; --i) {
    V acc[kG];
    for (int t = 0; t < kG; ++t) acc[t] = vload<V>(g.Wb[t / kT] + g.off(i, t));
    substitute_row(g, a.LB_cols + static_cast<std::size_t>(i) * M, i + 1, M, i, a.LB_inv_diag, acc);
  }
  for (int i = M - 1; i >= 0; --i) {
    V acc[kG];
    for (int t = 0; t < kG; ++t)
      acc[t] = inv_sqrt[t] * vload<V>(g.Wb[t / kT] + g.off(i, t)) - w[t] * vload<V>(g.Vb[t / kT] + g.off(i, t));
    substitute_row(g, a.L_cols + static_cast<std::size_t>(i) * M, i + 1, M, i, a.L_inv_diag, acc);
  }
}

/// Adds V diag(w) V^T (lower) to sums.VwV, block after block.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_vwv(const GradientArgs& a, const GradientGroup<V, P>& g, const V* w,
                                                GradientSums& sums) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M;
  for (int i = 0; i < M; ++i) {
    V wv[kG];
    for (int t = 0; t < kG; ++t) wv[t] = w[t] * vload<V>(g.Vb[t / kT] + g.off(i, t));
    double* row = sums.VwV.data() + static_cast<std::size_t>(i) * (i + 1) / 2 * kLanes;
    for (int j = 0; j <= i; ++j) {
      V prod[kG];
      for (int t = 0; t < kG; ++t) prod[t] = wv[t] * vload<V>(g.Vb[t / kT] + g.off(j, t));
      for (int p = 0; p < P; ++p) accumulate(row + j * kLanes, tree4(prod + p * kT));
    }
  }
}

/// Adds the gradient's data terms of pseudo-input m: q = E'(., m) = K(., m) .* G'(m, .) and
/// r = K(., m) .* a, their sums, and both times (x - p) and (x - p)^2 per input dimension.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_data_terms(const GradientArgs& a, const GradientGroup<V, P>& g, const V* av,
                                                       int m, GradientSums& sums) noexcept {
  constexpr int kT = GradientGroup<V, P>::kT, kG = GradientGroup<V, P>::kG;
  const int M = a.M, D = a.D;
  V q[kG], r[kG];
  for (int t = 0; t < kG; ++t) {
    const V k = vload<V>(g.K[t / kT] + g.off(m, t));
    q[t] = k * vload<V>(g.Wb[t / kT] + g.off(m, t));
    r[t] = k * av[t];
  }
  for (int p = 0; p < P; ++p) {
    accumulate(sums.q_sum.data() + m * kLanes, seq4(q + p * kT));
    accumulate(sums.r_sum.data() + m * kLanes, seq4(r + p * kT));
  }
  for (int d = 0; d < D; ++d) {
    const double pd = a.pseudo[d * M + m];
    V tq[kG], tr[kG], tq2[kG], tr2[kG];
    for (int t = 0; t < kG; ++t) {
      const V diff = vload<V>(g.x[t / kT] + g.off(d, t)) - pd;
      tq[t] = q[t] * diff;
      tr[t] = r[t] * diff;
      tq2[t] = tq[t] * diff;
      tr2[t] = tr[t] * diff;
    }
    const std::size_t e = (static_cast<std::size_t>(d) * M + m) * kLanes;
    for (int p = 0; p < P; ++p) {
      accumulate(sums.q_lin.data() + e, seq4(tq + p * kT));
      accumulate(sums.r_lin.data() + e, seq4(tr + p * kT));
      accumulate(sums.q_sq.data() + e, seq4(tq2 + p * kT));
      accumulate(sums.r_sq.data() + e, seq4(tr2 + p * kT));
    }
  }
}

/// Gradient pass over the P blocks blk0 .. blk0 + P - 1, side by side: per sample a = C^-1 y,
/// w = diag(C^-1) - a^2 and G'_n = L^-T (B^-1 u_n Lambda_n^-1/2 - w_n v_n) (G of fitc_evaluate without
/// its -a_n L^-T V a term, which needs all samples: the caller subtracts it from the sums),
/// E' = K_NM .* G'^T; the sums into `sums`, block after block as forward_group. W is scratch of
/// P M kBlock doubles.
template <class V, int P>
[[gnu::always_inline]] inline void gradient_group(const GradientArgs& a, const FitcBlocks& fb, Eigen::Index blk0,
                                                  GradientSums& sums, double* W) noexcept {
  constexpr int kG = GradientGroup<V, P>::kG;
  GradientGroup<V, P> g;
  gradient_group_blocks(a, fb, blk0, W, g);
  V lambda[kG], inv_sqrt[kG], av[kG], w[kG];
  gradient_a(a, fb, g, lambda, inv_sqrt, av);
  gradient_va_and_t(a, g, av, inv_sqrt, sums);
  gradient_w(a, fb, g, lambda, av, w, sums);
  gradient_g_prime(a, g, inv_sqrt, w);
  gradient_vwv(a, g, w, sums);
  for (int m = 0; m < a.M; ++m) gradient_data_terms(a, g, av, m, sums);
}

/// Gradient pass over blocks [b0, b1), P blocks at a time (gradient_group).
template <class V, int P>
[[gnu::always_inline]] inline void gradient_blocks(const GradientArgs& a, const FitcBlocks& fb, Eigen::Index b0,
                                                   Eigen::Index b1, GradientSums& sums, double* W) {
  static_assert(P >= 1 && P <= kMaxGroup);
  Eigen::Index blk = b0;
  for (; blk + P <= b1; blk += P) gradient_group<V, P>(a, fb, blk, sums, W);
  if constexpr (P > 1)
    for (; blk < b1; ++blk) gradient_group<V, 1>(a, fb, blk, sums, W);
}

/// The two passes for AVX2 and generic x86-64 (4-double vectors), picked at load time; no FMA in
/// either, so the same bits.
[[gnu::target_clones("avx2", "default")]] void fitc_forward_blocks(const ForwardArgs& a, FitcBlocks& fb,
                                                                   Eigen::Index b0, Eigen::Index b1,
                                                                   double* B_acc, double* Vy_acc, double* U) {
  forward_blocks<Lanes, 1>(a, fb, b0, b1, B_acc, Vy_acc, U);
}
[[gnu::target_clones("avx2", "default")]] void fitc_gradient_blocks(const GradientArgs& a, const FitcBlocks& fb,
                                                                    Eigen::Index b0, Eigen::Index b1,
                                                                    GradientSums& sums, double* W) {
  gradient_blocks<Lanes, 1>(a, fb, b0, b1, sums, W);
}

// The same passes on 8-double vectors (AVX-512; GCC only: clang, which builds only the fuzzers,
// refuses 64-byte vector helpers outside AVX-512 functions as it does the 32-byte ones without AVX).
// Chosen at run time when the CPU has AVX-512F/DQ/VL/BW; -ffp-contract=off keeps FMA out of them too.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define PEHA_SPGP_AVX512 1
using Lanes8 = double __attribute__((vector_size(8 * 2 * kLanes)));
[[gnu::target("avx512f,avx512dq,avx512vl,avx512bw")]] void fitc_forward_blocks_avx512(const ForwardArgs& a, FitcBlocks& fb,
                                                                             Eigen::Index b0, Eigen::Index b1,
                                                                             double* B_acc, double* Vy_acc, double* U) {
  forward_blocks<Lanes8, kMaxGroup>(a, fb, b0, b1, B_acc, Vy_acc, U);
}
[[gnu::target("avx512f,avx512dq,avx512vl,avx512bw")]] void fitc_gradient_blocks_avx512(const GradientArgs& a,
                                                                              const FitcBlocks& fb, Eigen::Index b0,
                                                                              Eigen::Index b1, GradientSums& sums,
                                                                              double* W) {
  gradient_blocks<Lanes8, kMaxGroup>(a, fb, b0, b1, sums, W);
}
#else
#define PEHA_SPGP_AVX512 0
#endif

/// Whether the passes may take the AVX-512 build (tests switch it off to compare the two).
bool g_spgp_avx512_allowed = true;

bool use_avx512_passes() {
#if PEHA_SPGP_AVX512
  static const bool supported = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                                __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
  return supported && g_spgp_avx512_allowed;
#else
  return false;
#endif
}

void forward_pass(const ForwardArgs& a, FitcBlocks& fb, Eigen::Index b0, Eigen::Index b1, double* B_acc,
                  double* Vy_acc, double* U) {
#if PEHA_SPGP_AVX512
  if (use_avx512_passes()) return fitc_forward_blocks_avx512(a, fb, b0, b1, B_acc, Vy_acc, U);
#endif
  fitc_forward_blocks(a, fb, b0, b1, B_acc, Vy_acc, U);
}

void gradient_pass(const GradientArgs& a, const FitcBlocks& fb, Eigen::Index b0, Eigen::Index b1,
                   GradientSums& sums, double* W) {
#if PEHA_SPGP_AVX512
  if (use_avx512_passes()) return fitc_gradient_blocks_avx512(a, fb, b0, b1, sums, W);
#endif
  fitc_gradient_blocks(a, fb, b0, b1, sums, W);
}

/// The samples into `fb` in blocks of kBlock (the last one padded with K = 0, y = 0: no
/// contribution), with room for what the forward pass writes. Returns the number of blocks.
Eigen::Index fill_blocks(const MatrixXd& X, const VectorXd& y, Eigen::Index M, FitcBlocks& fb) {
  const Eigen::Index N = X.rows(), D = X.cols();
  const Eigen::Index blocks = (N + kBlock - 1) / kBlock;
  const auto padded = static_cast<std::size_t>(blocks) * kBlock;
  const auto per_block = static_cast<std::size_t>(M) * kBlock;
  fb.X.assign(padded * static_cast<std::size_t>(D), 0.0);
  fb.y.assign(padded, 0.0);
  fb.valid.assign(padded, 0.0);
  for (Eigen::Index n = 0; n < N; ++n) {
    const auto blk = static_cast<std::size_t>(n / kBlock), q = static_cast<std::size_t>(n % kBlock);
    for (Eigen::Index d = 0; d < D; ++d) fb.X[(blk * static_cast<std::size_t>(D) + static_cast<std::size_t>(d)) * kBlock + q] = X(n, d);
    fb.y[static_cast<std::size_t>(n)] = y[n];
    fb.valid[static_cast<std::size_t>(n)] = 1.0;
  }
  fb.K.resize(static_cast<std::size_t>(blocks) * per_block);
  fb.V.resize(static_cast<std::size_t>(blocks) * per_block);
  fb.lambda.resize(padded);
  fb.y_over_lambda.resize(padded);
  return blocks;
}

/// Whether for_two_halves runs a second half over this many blocks (and there are its sums to add).
bool split_in_halves(Eigen::Index blocks) { return blocks >= kMinSplitBlocks; }

/// The forward pass over all blocks in two halves, each into its own accumulators in ws.
void forward_halves(const ForwardArgs& forward, Eigen::Index blocks, FitcWorkspace& ws) {
  const Eigen::Index M = forward.M;
  const auto per_block = static_cast<std::size_t>(M) * kBlock;
  const auto packed = static_cast<std::size_t>(M) * static_cast<std::size_t>(M + 1) / 2 * kLanes;
  std::vector<double>* const B_acc = ws.B_acc;
  std::vector<double>* const Vy_acc = ws.Vy_acc;
  for_two_halves(blocks, kMinSplitBlocks, ws.worker, [&](Eigen::Index b0, Eigen::Index b1, int h) {
    B_acc[h].assign(packed, 0.0);
    Vy_acc[h].assign(static_cast<std::size_t>(M) * kLanes, 0.0);
    ws.scratch[h].resize(kMaxGroup * per_block);
    forward_pass(forward, ws.blocks, b0, b1, B_acc[h].data(), Vy_acc[h].data(), ws.scratch[h].data());
  });
}

/// B = I + U U^T (lower triangle, into ws.B) and V Lambda^-1 y (into Vy, of size M) from the forward
/// pass's per-lane sums, of both halves if `split`.
void add_forward_sums(FitcWorkspace& ws, bool split, VectorXd& Vy) {
  const Eigen::Index M = Vy.size();
  const std::vector<double>* const B_acc = ws.B_acc;
  const std::vector<double>* const Vy_acc = ws.Vy_acc;
  MatrixXd& B = ws.B;
  B.setIdentity(M, M);
  for (Eigen::Index i = 0; i < M; ++i) {
    for (Eigen::Index j = 0; j <= i; ++j) {
      const auto at = (static_cast<std::size_t>(i) * static_cast<std::size_t>(i + 1) / 2 + static_cast<std::size_t>(j)) * kLanes;
      B(i, j) += lane_sum(B_acc[0].data() + at) + (split ? lane_sum(B_acc[1].data() + at) : 0.0);
    }
    const auto at = static_cast<std::size_t>(i) * kLanes;
    Vy[i] = lane_sum(Vy_acc[0].data() + at) + (split ? lane_sum(Vy_acc[1].data() + at) : 0.0);
  }
}

/// The gradient pass over all blocks in two halves, each into its own sums in ws.
void gradient_halves(const GradientArgs& backward, Eigen::Index blocks, FitcWorkspace& ws) {
  const auto per_block = static_cast<std::size_t>(backward.M) * kBlock;
  GradientSums* const sums = ws.sums;
  for_two_halves(blocks, kMinSplitBlocks, ws.worker, [&](Eigen::Index b0, Eigen::Index b1, int h) {
    sums[h].reset(backward.M, backward.D);
    ws.scratch[h].resize(kMaxGroup * per_block);
    gradient_pass(backward, ws.blocks, b0, b1, sums[h], ws.scratch[h].data());
  });
}

/// The gradient pass's sums over all samples, with G's -g a^T term put in.
struct GradientTotals {
  VectorXd Va;        ///< V a
  MatrixXd VwV;       ///< lower triangle: V diag(w) V^T
  VectorXd g;         ///< L^-T V a: G = G' - g a^T
  MatrixXd data_lin;  ///< M x D: sum_n E(n, m) (X(n, d) - pseudo(m, d))
  VectorXd data_sq;   ///< D: sum_n,m E(n, m) (X(n, d) - pseudo(m, d))^2
  double E_sum = 0.0, w_sum = 0.0;
};

/// The totals of the gradient pass's per-lane sums (of both halves if `split`).
void add_gradient_sums(const FitcWorkspace& ws, bool split, const Eigen::LLT<MatrixXd>& llt_mm, Eigen::Index D,
                       GradientTotals& totals) {
  const Eigen::Index M = llt_mm.rows();
  const GradientSums* const sums = ws.sums;
  // One total of four lanes (and of the two halves).
  auto total = [&](std::vector<double> GradientSums::*part, std::size_t entry) {
    const std::size_t at = entry * kLanes;
    return lane_sum((sums[0].*part).data() + at) + (split ? lane_sum((sums[1].*part).data() + at) : 0.0);
  };
  VectorXd& Va = totals.Va;
  Va.resize(M);
  totals.VwV.resize(M, M);
  for (Eigen::Index i = 0; i < M; ++i) {
    Va[i] = total(&GradientSums::Va, static_cast<std::size_t>(i));
    for (Eigen::Index j = 0; j <= i; ++j)
      totals.VwV(i, j) = total(&GradientSums::VwV, static_cast<std::size_t>(i) * static_cast<std::size_t>(i + 1) / 2 + static_cast<std::size_t>(j));
  }
  totals.g = llt_mm.matrixU().solve(Va);
  const VectorXd& g = totals.g;
  totals.data_lin.resize(M, D);
  totals.data_sq.setZero(D);
  for (Eigen::Index m = 0; m < M; ++m) {
    const auto um = static_cast<std::size_t>(m);
    totals.E_sum += total(&GradientSums::q_sum, um) - g[m] * total(&GradientSums::r_sum, um);
    for (Eigen::Index d = 0; d < D; ++d) {
      const std::size_t e = static_cast<std::size_t>(d) * static_cast<std::size_t>(M) + um;
      totals.data_lin(m, d) = total(&GradientSums::q_lin, e) - g[m] * total(&GradientSums::r_lin, e);
      totals.data_sq[d] += total(&GradientSums::q_sq, e) - g[m] * total(&GradientSums::r_sq, e);
    }
  }
  totals.w_sum = total(&GradientSums::w_sum, 0);
}

/// The gradient [vec(pseudo), log_b, log_c, log_sigma2] from the totals. H = L^-T S L^-1 with
/// S = I - B^-1 - V diag(w) V^T - (V a)(V a)^T, and F = H .* K_MM is dK_MM's coefficient (x -2).
void assemble_gradient(const MatrixXd& pseudo, const KernelScales& k, const GradientTotals& totals,
                       const Eigen::LLT<MatrixXd>& llt_b, const Eigen::LLT<MatrixXd>& llt_mm,
                       const MatrixXd& Kmm_kernel, VectorXd& grad) {
  const Eigen::Index M = pseudo.rows(), D = pseudo.cols();
  const auto Lt = llt_mm.matrixU();
  MatrixXd S = -totals.VwV;  // lower triangle
  S.triangularView<Eigen::Lower>() -= totals.Va * totals.Va.transpose();
  S.triangularView<Eigen::Lower>() -= llt_b.solve(MatrixXd::Identity(M, M));
  S.diagonal().array() += 1.0;
  S = S.selfadjointView<Eigen::Lower>();
  const MatrixXd T = Lt.solve(S);                    // L^-T S
  MatrixXd H = Lt.solve(T.transpose()).transpose();  // L^-T S L^-1
  H = 0.5 * (H + H.transpose());
  const MatrixXd F = H.cwiseProduct(Kmm_kernel);

  grad.setZero(M * D + D + 2);
  for (Eigen::Index d = 0; d < D; ++d) {
    double pseudo_sq = 0.0;
    for (Eigen::Index m = 0; m < M; ++m) {
      const double xb = pseudo(m, d);
      double pseudo_lin = 0.0;
      for (Eigen::Index j = 0; j < M; ++j) {
        const double diff = xb - pseudo(j, d);
        pseudo_lin += F(m, j) * diff;
        pseudo_sq += F(m, j) * diff * diff;
      }
      grad[d * M + m] = k.b[d] * (totals.data_lin(m, d) + pseudo_lin);
    }
    grad[M * D + d] = -0.5 * k.b[d] * totals.data_sq[d] + 0.25 * k.b[d] * pseudo_sq;
  }
  grad[M * D + D] = totals.E_sum - 0.5 * F.sum() + 0.5 * k.c * totals.w_sum;
  grad[M * D + D + 1] = 0.5 * k.sigma2 * totals.w_sum;
}

/// The FITC NLML in O(N M^2), and whatever `request` asks for from the same factorisations.
/// Returns +inf when K_MM, Lambda or B is not positive definite (numerically).
///
/// Notation (Snelson's spgp_lik, with L L^T = K_MM):
///   V = L^-1 K_MN,  Lambda_n = c - |V_n|^2 + sigma^2,  U = V Lambda^-1/2,
///   B = I + U U^T = L^-1 A L^-T with A = K_MM + K_MN Lambda^-1 K_NM,  L_B L_B^T = B,
///   log|C| = log|B| + sum log Lambda_n,  y^T C^-1 y = y^T Lambda^-1 y - |L_B^-1 V Lambda^-1 y|^2.
/// B's eigenvalues are >= 1, so its Cholesky is far better conditioned than A's.
///
/// Gradient: dNLML = 1/2 tr(W dC) with W = C^-1 - a a^T, a = C^-1 y. Since
/// dC = dQ - diag(dQ) + diag(dK_NN) + d(sigma^2) I and dQ = dK_NM P + P^T dK_MN - P^T dK_MM P with
/// P = K_MM^-1 K_MN, everything reduces to G = P (W - diag(W)) (M x N), the coefficient of dK_NM^T,
/// and H = G P^T (M x M), whose -1/2 multiple is the coefficient of dK_MM. Using
/// P C^-1 = A^-1 K_MN Lambda^-1:  G = L^-T Z,  Z = B^-1 V Lambda^-1 - (V a) a^T - V diag(w),
/// w = diag(W) = diag(C^-1) - a^2 with diag(C^-1)_n = (1 - u_n^T B^-1 u_n) / Lambda_n,
/// H = L^-T S L^-1 with S = Z V^T = I - B^-1 - V diag(w) V^T - (V a)(V a)^T (since
/// V Lambda^-1 V^T = B - I): a symmetric rank-N update instead of a general M x N x M product.
/// G = G' - g a^T with g = L^-T V a, so the sums over samples the gradient needs (of E = K_NM .* G^T
/// and its products with x - p) come from E' = K_NM .* G'^T and K_NM .* a in the same pass.
///
/// Two passes over the samples (fitc_forward_blocks before the M x M factorisation of B,
/// fitc_gradient_blocks after it), each in two halves of the sample blocks on two threads; the sums
/// over samples are added from per-lane accumulators and the halves at the end. Same formulas as
/// fitc_evaluate_reference, different summation order (and the exp of the prediction): the NLML
/// agrees to ~1e-13 relative (tests: 1e-9).
double fitc_evaluate(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper,
                     double jitter, const FitcRequest& request, FitcWorkspace& ws) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::Index N = X.rows(), M = pseudo.rows(), D = X.cols();
  if (D > kMaxInputDim) reject("input dimension " + std::to_string(D) + " exceeds " + std::to_string(kMaxInputDim));
  const KernelScales k = scales_and_kmm(pseudo, hyper, jitter, ws);
  const Eigen::LLT<MatrixXd> llt_mm(ws.Kmm);
  if (llt_mm.info() != Eigen::Success) return kInf;
  const auto L = llt_mm.matrixL();
  const auto Lt = llt_mm.matrixU();
  const MatrixXd L_cols = L;  // zero above the diagonal
  const MatrixXd L_rows = L_cols.transpose();
  const VectorXd L_inv_diag = L_cols.diagonal().cwiseInverse();

  const Eigen::Index blocks = fill_blocks(X, y, M, ws.blocks);
  const bool split = split_in_halves(blocks);
  const ForwardArgs forward{static_cast<int>(M), static_cast<int>(D), pseudo.data(), k.b.data(), k.c, k.c + k.sigma2,
                            L_rows.data(), L_inv_diag.data()};
  forward_halves(forward, blocks, ws);
  // The temporaries from here on are allocated in this order so that the heap's top is not trimmed
  // and grown again every evaluation.
  const VectorXd lambda = Eigen::Map<const VectorXd>(ws.blocks.lambda.data(), N);
  if (!(lambda.minCoeff() > 0.0) || !lambda.allFinite()) return kInf;
  const VectorXd y_over_lambda = Eigen::Map<const VectorXd>(ws.blocks.y_over_lambda.data(), N);
  VectorXd Vy(M);
  add_forward_sums(ws, split, Vy);
  const Eigen::LLT<MatrixXd> llt_b(ws.B);  // reads the lower triangle only
  if (llt_b.info() != Eigen::Success) return kInf;

  const VectorXd beta = llt_b.matrixL().solve(Vy);
  VectorXd gamma;
  const double nlml = nlml_and_outputs(llt_b, beta, y, y_over_lambda, lambda, L, Lt, request, gamma);
  if (!std::isfinite(nlml)) return kInf;
  if (request.gradient == nullptr) return nlml;

  const MatrixXd LB_cols = llt_b.matrixL();
  const MatrixXd LB_rows = LB_cols.transpose();
  const VectorXd LB_inv_diag = LB_cols.diagonal().cwiseInverse();
  const GradientArgs backward{static_cast<int>(M), static_cast<int>(D), pseudo.data(), gamma.data(),
                              LB_rows.data(), LB_cols.data(), LB_inv_diag.data(), L_cols.data(), L_inv_diag.data()};
  gradient_halves(backward, blocks, ws);
  GradientTotals totals;
  add_gradient_sums(ws, split, llt_mm, D, totals);
  assemble_gradient(pseudo, k, totals, llt_b, llt_mm, ws.Kmm_kernel, *request.gradient);
  return nlml;
}
/// Parameter vector layout of the optimiser: [vec(pseudo) (M*D, column-major), log_b, log_c, log_sigma2].
struct ParamLayout {
  Eigen::Index M, D;
  Eigen::Index size() const { return M * D + D + 2; }
  MatrixXd pseudo(const double* p) const { return Eigen::Map<const MatrixXd>(p, M, D); }
  SpgpHyper hyper(const double* p) const {
    SpgpHyper h;
    h.log_b = Eigen::Map<const VectorXd>(p + M * D, D);
    h.log_c = p[M * D + D];
    h.log_sigma2 = p[M * D + D + 1];
    return h;
  }
  VectorXd pack(const MatrixXd& pseudo, const SpgpHyper& h) const {
    VectorXd p(size());
    p.head(M * D) = Eigen::Map<const VectorXd>(pseudo.data(), M * D);
    p.segment(M * D, D) = h.log_b;
    p[M * D + D] = h.log_c;
    p[M * D + D + 1] = h.log_sigma2;
    return p;
  }
};

/// The FITC NLML as Ceres sees it. A failed evaluation (not positive definite, overflow) makes the
/// line search step back instead of stopping the fit.
class FitcObjective final : public ceres::FirstOrderFunction {
 public:
  FitcObjective(const MatrixXd& X, const VectorXd& y, ParamLayout layout, double jitter, bool prior)
      : X_(X), y_(y), layout_(layout), jitter_(jitter), prior_(prior) {}

  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    const SpgpHyper h = layout_.hyper(parameters);
    if (!(h.log_b.cwiseAbs().maxCoeff() < kMaxAbsLogHyper && std::abs(h.log_c) < kMaxAbsLogHyper &&
          std::abs(h.log_sigma2) < kMaxAbsLogHyper))
      return false;
    VectorXd g;
    *cost = fitc_evaluate(X_, y_, layout_.pseudo(parameters), h, jitter_,
                          FitcRequest{gradient != nullptr ? &g : nullptr}, workspace_);
    if (!std::isfinite(*cost)) return false;
    if (gradient != nullptr) {
      if (!g.allFinite()) return false;
      Eigen::Map<VectorXd>(gradient, layout_.size()) = g;
    }
    if (prior_) {
      // Log-normal hyperpriors (see SpgpOptions::hyper_prior): -log p up to a constant.
      constexpr double kLogCSd = 1.0, kLogSigma2Mean = -4.605170185988091 /* log 0.01 */, kLogSigma2Sd = 2.0;
      const double zc = h.log_c / kLogCSd, zs = (h.log_sigma2 - kLogSigma2Mean) / kLogSigma2Sd;
      *cost += 0.5 * (zc * zc + zs * zs);
      if (gradient != nullptr) {
        gradient[layout_.size() - 2] += zc / kLogCSd;
        gradient[layout_.size() - 1] += zs / kLogSigma2Sd;
      }
    }
    return true;
  }
  int NumParameters() const override { return static_cast<int>(layout_.size()); }

 private:
  const MatrixXd& X_;
  const VectorXd& y_;
  ParamLayout layout_;
  double jitter_;
  bool prior_;
  mutable FitcWorkspace workspace_;  // scratch only; Ceres evaluates from one thread here
};

/// Forwards Ceres' per-iteration summary to the user's progress function.
class ProgressCallback final : public ceres::IterationCallback {
 public:
  explicit ProgressCallback(const std::function<void(int, double)>& progress) : progress_(progress) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    progress_(summary.iteration, summary.cost);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(int, double)>& progress_;
};

/// Sample mean and standard deviation; a constant column gets scale 1 so that standardising
/// does not divide by zero (its length scale then simply stays uninformative).
std::pair<double, double> mean_and_scale(const Eigen::Ref<const VectorXd>& v) {
  const double mean = v.mean();
  const double n = static_cast<double>(v.size());
  const double var = v.size() > 1 ? (v.array() - mean).square().sum() / (n - 1.0) : 0.0;
  const double scale = std::sqrt(var);
  return {mean, scale > 0.0 && std::isfinite(scale) ? scale : 1.0};
}


/// Writes k_m / c = exp(-sum_d (x'_d - P'_dm)^2) for m in [0, padded) into k (when not null; padded
/// is a multiple of kLanes) and returns sum_m weight_m k_m / c. kDim > 0: the input dimension known
/// at compile time (x' broadcast once, the d loop unrolled); 0: any D <= kMaxInputDim.
template <int kDim>
[[gnu::always_inline]] inline double pseudo_kernel_pass_impl(const double* x_scaled, int D, const double* scaled_pseudo,
                                                             int padded, const double* weight, double* k) {
  const int dims = kDim > 0 ? kDim : D;
  Lanes x[kDim > 0 ? kDim : kMaxInputDim];
  for (int d = 0; d < dims; ++d) x[d] = splat(x_scaled[d]);
  Lanes sum = splat(0.0);
  for (int m = 0; m < padded; m += kLanes) {
    Lanes exponent = splat(0.0);
    for (int d = 0; d < dims; ++d) {
      const Lanes diff = x[d] - load_lanes(scaled_pseudo + static_cast<std::size_t>(d) * padded + m);
      exponent -= diff * diff;
    }
    const Lanes e = exp_nonpositive(exponent);
    if (k != nullptr) std::memcpy(k + m, &e, sizeof e);
    sum += load_lanes(weight + m) * e;
  }
  return (sum[0] + sum[1]) + (sum[2] + sum[3]);
}

/// pseudo_kernel_pass_impl for the model's D (the calibration's residual has D = 2). AVX2 and
/// generic builds, picked at load time.
[[gnu::target_clones("avx2", "default")]] double pseudo_kernel_pass(const double* x_scaled, int D,
                                                                    const double* scaled_pseudo, int padded,
                                                                    const double* weight, double* k) {
  switch (D) {
    case 1: return pseudo_kernel_pass_impl<1>(x_scaled, D, scaled_pseudo, padded, weight, k);
    case 2: return pseudo_kernel_pass_impl<2>(x_scaled, D, scaled_pseudo, padded, weight, k);
    case 3: return pseudo_kernel_pass_impl<3>(x_scaled, D, scaled_pseudo, padded, weight, k);
    default: return pseudo_kernel_pass_impl<0>(x_scaled, D, scaled_pseudo, padded, weight, k);
  }
}

/// pseudo_kernel_pass_impl (k = nullptr) for two inputs at once: each lane's exponent and sum take
/// exactly the operations of the single pass, so the two results are its results bit for bit.
template <int kDim>
[[gnu::always_inline]] inline void pseudo_kernel_pair_impl(const double* xa_scaled, const double* xb_scaled, int D,
                                                           const double* scaled_pseudo, int padded, const double* weight,
                                                           double out[2]) {
  const int dims = kDim > 0 ? kDim : D;
  Lanes xa[kDim > 0 ? kDim : kMaxInputDim], xb[kDim > 0 ? kDim : kMaxInputDim];
  for (int d = 0; d < dims; ++d) xa[d] = splat(xa_scaled[d]), xb[d] = splat(xb_scaled[d]);
  Lanes sum_a = splat(0.0), sum_b = splat(0.0);
  for (int m = 0; m < padded; m += kLanes) {
    Lanes exponent_a = splat(0.0), exponent_b = splat(0.0);
    for (int d = 0; d < dims; ++d) {
      const Lanes p = load_lanes(scaled_pseudo + static_cast<std::size_t>(d) * padded + m);
      const Lanes diff_a = xa[d] - p, diff_b = xb[d] - p;
      exponent_a -= diff_a * diff_a;
      exponent_b -= diff_b * diff_b;
    }
    const Lanes w = load_lanes(weight + m);
    sum_a += w * exp_nonpositive(exponent_a);
    sum_b += w * exp_nonpositive(exponent_b);
  }
  out[0] = (sum_a[0] + sum_a[1]) + (sum_a[2] + sum_a[3]);
  out[1] = (sum_b[0] + sum_b[1]) + (sum_b[2] + sum_b[3]);
}

[[gnu::target_clones("avx2", "default")]] void pseudo_kernel_pair(const double* xa_scaled, const double* xb_scaled, int D,
                                                                  const double* scaled_pseudo, int padded, const double* weight,
                                                                  double out[2]) {
  switch (D) {
    case 1: return pseudo_kernel_pair_impl<1>(xa_scaled, xb_scaled, D, scaled_pseudo, padded, weight, out);
    case 2: return pseudo_kernel_pair_impl<2>(xa_scaled, xb_scaled, D, scaled_pseudo, padded, weight, out);
    case 3: return pseudo_kernel_pair_impl<3>(xa_scaled, xb_scaled, D, scaled_pseudo, padded, weight, out);
    default: return pseudo_kernel_pair_impl<0>(xa_scaled, xb_scaled, D, scaled_pseudo, padded, weight, out);
  }
}

}  // namespace

double spgp_nlml(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper,
                 double jitter, VectorXd* gradient) {
  check_problem_shapes(X, y, pseudo, hyper);
  FitcWorkspace workspace;
  const double nlml = fitc_evaluate(X, y, pseudo, hyper, jitter, FitcRequest{gradient}, workspace);
  if (gradient != nullptr && !std::isfinite(nlml))
    gradient->setConstant(pseudo.size() + X.cols() + 2, std::numeric_limits<double>::quiet_NaN());
  return nlml;
}

namespace detail {
/// spgp_nlml by fitc_evaluate_reference (tests: the parallel evaluation against the original).
double spgp_nlml_reference(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper,
                           double jitter, VectorXd* gradient) {
  check_problem_shapes(X, y, pseudo, hyper);
  FitcWorkspace workspace;
  return fitc_evaluate_reference(X, y, pseudo, hyper, jitter, FitcRequest{gradient}, workspace);
}

/// Allows (true, the default) or forbids the AVX-512 build of the blocked passes; returns the previous
/// setting (tests: both builds give the same bits). Not thread-safe: call it between fits.
bool spgp_allow_avx512(bool allowed) {
  const bool previous = g_spgp_avx512_allowed;
  g_spgp_avx512_allowed = allowed;
  return previous;
}

/// Whether the blocked passes run the AVX-512 build (the CPU has it and it is allowed).
bool spgp_uses_avx512() { return use_avx512_passes(); }
}  // namespace detail

double spgp_nlml_dense(const MatrixXd& X, const VectorXd& y, const MatrixXd& pseudo, const SpgpHyper& hyper,
                       double jitter) {
  check_problem_shapes(X, y, pseudo, hyper);
  const VectorXd b = hyper.log_b.array().exp().matrix();
  const double c = std::exp(hyper.log_c);
  MatrixXd Kmm = ard_kernel(pseudo, pseudo, b, c);
  Kmm.diagonal().array() += jitter;
  const MatrixXd Kmn = ard_kernel(pseudo, X, b, c);
  const MatrixXd Q = Kmn.transpose() * Kmm.llt().solve(Kmn);
  MatrixXd C = Q;
  // K_NN's diagonal is c: C = Q + diag(c - Q) + sigma^2 I.
  C.diagonal().setConstant(c + std::exp(hyper.log_sigma2));
  const Eigen::LLT<MatrixXd> llt(C);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const double log_det = 2.0 * llt.matrixLLT().diagonal().array().log().sum();
  return 0.5 * (log_det + y.dot(llt.solve(y)) + static_cast<double>(X.rows()) * std::log(2.0 * std::numbers::pi));
}

Spgp Spgp::fit(const MatrixXd& X, const VectorXd& y, const SpgpOptions& options,
               const std::function<void(int iteration, double nlml)>& progress) {
  const Eigen::Index N = X.rows(), D = X.cols();
  const Eigen::Index M = options.num_pseudo;
  if (X.rows() != y.size()) reject("X has " + std::to_string(X.rows()) + " rows but y has " + std::to_string(y.size()));
  if (N < 1 || D < 1) reject("X is " + shape(N, D) + ", expected at least 1 x 1");
  if (D > kMaxInputDim) reject("input dimension " + std::to_string(D) + " exceeds " + std::to_string(kMaxInputDim));
  if (M < 1 || M > N)
    reject("num_pseudo = " + std::to_string(M) + ", expected 1 .. N = " + std::to_string(N));
  if (options.max_iterations < 0) reject("max_iterations = " + std::to_string(options.max_iterations) + " < 0");
  if (!(options.jitter > 0.0) || !std::isfinite(options.jitter)) reject("jitter must be finite and > 0");
  if (!X.allFinite()) reject("X contains non-finite values");
  if (!y.allFinite()) reject("y contains non-finite values");

  Spgp model;
  model.input_mean_.resize(D);
  model.input_scale_.resize(D);
  for (Eigen::Index d = 0; d < D; ++d)
    std::tie(model.input_mean_[d], model.input_scale_[d]) = mean_and_scale(X.col(d));
  std::tie(model.output_mean_, model.output_scale_) = mean_and_scale(y);
  const MatrixXd Xs = (X.rowwise() - model.input_mean_.transpose()).array().rowwise() /
                      model.input_scale_.transpose().array();
  const VectorXd ys = (y.array() - model.output_mean_) / model.output_scale_;

  // Initial pseudo-inputs: M distinct data points (partial Fisher-Yates; plain modulo so the
  // sequence is the same on every standard library).
  std::mt19937_64 rng(options.seed);
  std::vector<Eigen::Index> order(static_cast<std::size_t>(N));
  for (Eigen::Index i = 0; i < N; ++i) order[static_cast<std::size_t>(i)] = i;
  MatrixXd pseudo(M, D);
  for (Eigen::Index m = 0; m < M; ++m) {
    const auto pick = static_cast<std::size_t>(m) + static_cast<std::size_t>(rng() % static_cast<std::uint64_t>(N - m));
    std::swap(order[static_cast<std::size_t>(m)], order[pick]);
    pseudo.row(m) = Xs.row(order[static_cast<std::size_t>(m)]);
  }

  // Initial hypers as in Snelson's demo: length scale = half the data range; signal variance =
  // var(y) = 1 after standardising; noise = a tenth of it.
  SpgpHyper hyper;
  hyper.log_b.resize(D);
  for (Eigen::Index d = 0; d < D; ++d) {
    const double half_range = 0.5 * (Xs.col(d).maxCoeff() - Xs.col(d).minCoeff());
    hyper.log_b[d] = half_range > 0.0 ? -2.0 * std::log(half_range) : 0.0;
  }
  hyper.log_c = std::log(std::max(ys.squaredNorm() / static_cast<double>(N), 1e-6));
  hyper.log_sigma2 = hyper.log_c + std::log(0.1);

  const ParamLayout layout{M, D};
  VectorXd params = layout.pack(pseudo, hyper);
  if (options.max_iterations > 0) {
    ceres::GradientProblem problem(new FitcObjective(Xs, ys, layout, options.jitter, options.hyper_prior));
    ceres::GradientProblemSolver::Options solver_options;
    solver_options.line_search_direction_type = ceres::LBFGS;
    solver_options.max_num_iterations = options.max_iterations;
    // Stop on max_iterations or a stalled objective, not on Ceres' looser default (1e-6 relative).
    solver_options.function_tolerance = 1e-10;
    solver_options.logging_type = ceres::SILENT;
    ProgressCallback callback(progress);
    if (progress) solver_options.callbacks.push_back(&callback);
    ceres::GradientProblemSolver::Summary summary;
    ceres::Solve(solver_options, problem, params.data(), &summary);
    model.iterations_ = summary.iterations.empty() ? 0 : summary.iterations.back().iteration;
  }

  model.pseudo_ = layout.pseudo(params.data());
  model.hyper_ = layout.hyper(params.data());
  model.jitter_ = options.jitter;
  FitcWorkspace workspace;
  model.final_nlml_ = fitc_evaluate(Xs, ys, model.pseudo_, model.hyper_, model.jitter_,
                                    FitcRequest{nullptr, &model.alpha_, &model.var_}, workspace);
  // Ceres only accepts evaluated points, so this holds unless the initial point already failed.
  if (!std::isfinite(model.final_nlml_))
    throw std::runtime_error("Spgp::fit: the FITC covariance is not positive definite at the initial point");
  model.prepare();
  return model;
}

Spgp Spgp::from_parts(const VectorXd& input_mean, const VectorXd& input_scale, double output_mean,
                      double output_scale, const SpgpHyper& hyper, const MatrixXd& pseudo_inputs, double jitter,
                      const VectorXd& alpha, const MatrixXd& variance_matrix) {
  const Eigen::Index D = input_mean.size(), M = pseudo_inputs.rows();
  if (D < 1 || D > kMaxInputDim)
    reject("input_mean has " + std::to_string(D) + " entries, expected 1 .. " + std::to_string(kMaxInputDim));
  if (input_scale.size() != D)
    reject("input_scale has " + std::to_string(input_scale.size()) + " entries, expected " + std::to_string(D));
  if (hyper.log_b.size() != D)
    reject("log_b has " + std::to_string(hyper.log_b.size()) + " entries, expected " + std::to_string(D));
  if (M < 1 || pseudo_inputs.cols() != D)
    reject("pseudo_inputs is " + shape(M, pseudo_inputs.cols()) + ", expected M x " + std::to_string(D) + ", M >= 1");
  if (alpha.size() != M) reject("alpha has " + std::to_string(alpha.size()) + " entries, expected " + std::to_string(M));
  if (variance_matrix.rows() != M || variance_matrix.cols() != M)
    reject("variance_matrix is " + shape(variance_matrix.rows(), variance_matrix.cols()) + ", expected " +
           shape(M, M));
  if (!input_mean.allFinite() || !std::isfinite(output_mean)) reject("non-finite mean");
  if (!(input_scale.array() > 0.0).all() || !input_scale.allFinite() || !(output_scale > 0.0) ||
      !std::isfinite(output_scale))
    reject("scales must be finite and > 0");
  if (!hyper.log_b.allFinite() || !std::isfinite(hyper.log_c) || !std::isfinite(hyper.log_sigma2))
    reject("non-finite hyperparameter");
  if (!pseudo_inputs.allFinite() || !alpha.allFinite() || !variance_matrix.allFinite())
    reject("non-finite pseudo-inputs, alpha or variance_matrix");
  if (!(jitter >= 0.0) || !std::isfinite(jitter)) reject("jitter must be finite and >= 0");

  Spgp model;
  model.input_mean_ = input_mean;
  model.input_scale_ = input_scale;
  model.output_mean_ = output_mean;
  model.output_scale_ = output_scale;
  model.hyper_ = hyper;
  model.pseudo_ = pseudo_inputs;
  model.jitter_ = jitter;
  model.alpha_ = alpha;
  model.var_ = variance_matrix;
  model.prepare();
  return model;
}

void Spgp::prepare() {
  const int D = input_dim(), M = num_pseudo();
  padded_pseudo_ = (M + kLanes - 1) / kLanes * kLanes;
  const double c = std::exp(hyper_.log_c);
  input_gain_.resize(static_cast<std::size_t>(D));
  scaled_pseudo_.assign(static_cast<std::size_t>(D) * static_cast<std::size_t>(padded_pseudo_), 0.0);
  for (int d = 0; d < D; ++d) {
    const double s = std::sqrt(0.5 * std::exp(hyper_.log_b[d]));
    input_gain_[static_cast<std::size_t>(d)] = s / input_scale_[d];
    for (int m = 0; m < M; ++m)
      scaled_pseudo_[static_cast<std::size_t>(d) * static_cast<std::size_t>(padded_pseudo_) +
                     static_cast<std::size_t>(m)] = pseudo_(m, d) * s;
  }
  mean_weight_.assign(static_cast<std::size_t>(padded_pseudo_), 0.0);
  for (int m = 0; m < M; ++m) mean_weight_[static_cast<std::size_t>(m)] = output_scale_ * c * alpha_[m];
}

double Spgp::predict_mean(const double* x) const noexcept {
  if (padded_pseudo_ == 0) return output_mean_;  // default-constructed: no model, no residual
  const int D = input_dim();
  double x_scaled[kMaxInputDim];
  for (int d = 0; d < D; ++d)
    x_scaled[d] = (x[d] - input_mean_[d]) * input_gain_[static_cast<std::size_t>(d)];
  return output_mean_ +
         pseudo_kernel_pass(x_scaled, D, scaled_pseudo_.data(), padded_pseudo_, mean_weight_.data(), nullptr);
}

void Spgp::predict_mean_pair(const double* xa, const double* xb, double out[2]) const noexcept {
  if (padded_pseudo_ == 0) {  // default-constructed: no model, no residual
    out[0] = out[1] = output_mean_;
    return;
  }
  const int D = input_dim();
  double xa_scaled[kMaxInputDim], xb_scaled[kMaxInputDim];
  for (int d = 0; d < D; ++d) {
    xa_scaled[d] = (xa[d] - input_mean_[d]) * input_gain_[static_cast<std::size_t>(d)];
    xb_scaled[d] = (xb[d] - input_mean_[d]) * input_gain_[static_cast<std::size_t>(d)];
  }
  double sums[2];
  pseudo_kernel_pair(xa_scaled, xb_scaled, D, scaled_pseudo_.data(), padded_pseudo_, mean_weight_.data(), sums);
  out[0] = output_mean_ + sums[0];
  out[1] = output_mean_ + sums[1];
}

double Spgp::predict_mean_and_variance(const double* x, double* variance) const {
  if (padded_pseudo_ == 0) {  // default-constructed: no model, no claim
    *variance = 0.0;
    return output_mean_;
  }
  const int D = input_dim(), M = num_pseudo();
  double x_scaled[kMaxInputDim];
  for (int d = 0; d < D; ++d)
    x_scaled[d] = (x[d] - input_mean_[d]) * input_gain_[static_cast<std::size_t>(d)];
  double stack[kMaxStackPseudo + kLanes];
  std::vector<double> heap;
  double* k = stack;
  if (padded_pseudo_ > kMaxStackPseudo) {
    heap.resize(static_cast<std::size_t>(padded_pseudo_));
    k = heap.data();
  }
  const double mean = output_mean_ + pseudo_kernel_pass(x_scaled, D, scaled_pseudo_.data(), padded_pseudo_,
                                                        mean_weight_.data(), k);
  // var = c - k^T V k with k = c k' (k' from the pass): c - c^2 k'^T V k'.
  const double c = std::exp(hyper_.log_c);
  const Eigen::Map<const VectorXd> kv(k, M);
  double quadratic = 0.0;  // k'^T V k' column by column (no temporary vector)
  for (int j = 0; j < M; ++j) quadratic += k[j] * var_.col(j).dot(kv);
  const double var_std = c - c * c * quadratic;
  // The exact value is >= 0; round-off near the data can make it slightly negative.
  *variance = std::max(var_std, 0.0) * output_scale_ * output_scale_;
  return mean;
}

double Spgp::predict_variance(const double* x) const {
  double variance = 0.0;
  predict_mean_and_variance(x, &variance);
  return variance;
}

}  // namespace peha::calibration
