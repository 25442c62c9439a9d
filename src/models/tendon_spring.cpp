#include "peha/models/tendon_spring.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace peha::models {

namespace {

/// Contraction where g stops decreasing (the vertex of an upward parabola), +inf otherwise.
double vertex_contraction(const TendonSpringParams& p) noexcept {
  return p.a_N_per_Pa > 0.0 ? -p.b_N_per_Pa / (2.0 * p.a_N_per_Pa) : std::numeric_limits<double>::infinity();
}

}  // namespace

double gain_N_per_Pa(const TendonSpringParams& p, double u) noexcept {
  u = std::min(u, vertex_contraction(p));
  return (p.a_N_per_Pa * u + p.b_N_per_Pa) * u + p.c_N_per_Pa;
}

double forward_force_N(const TendonSpringParams& p, double pressure_Pa, double eps) noexcept {
  if (!(pressure_Pa > 0.0) || !std::isfinite(pressure_Pa) || !std::isfinite(eps)) return 0.0;
  const double s = eps + p.eps0;
  // h(F) = P*g(s + F/k) - F = A F^2 + B F + C; h(0) = C is the force the muscle would make with a
  // rigid wire. If that is not positive the muscle cannot pull here.
  const double C = pressure_Pa * gain_N_per_Pa(p, s);
  if (!(C > 0.0)) return 0.0;
  // Past the vertex of an upward parabola g is held constant (a muscle does not pull harder the
  // further it contracts). If the force that takes u to the vertex is not reached, F = P*g(vertex).
  const double u_vertex = vertex_contraction(p);
  if (std::isfinite(u_vertex)) {
    const double g_vertex = gain_N_per_Pa(p, u_vertex);
    const double F_vertex = p.k_N * (u_vertex - s);
    if (F_vertex <= 0.0 || pressure_Pa * g_vertex >= F_vertex) return std::max(0.0, pressure_Pa * g_vertex);
  }
  const double inv_k = 1.0 / p.k_N;
  const double A = pressure_Pa * p.a_N_per_Pa * inv_k * inv_k;
  const double B = pressure_Pa * (2.0 * p.a_N_per_Pa * s + p.b_N_per_Pa) * inv_k - 1.0;
  if (std::abs(A) < 1e-300 * std::max(1.0, std::abs(B))) {
    // Linear: B F + C = 0. With C > 0, a root >= 0 needs B < 0 (else h never reaches zero).
    return B < 0.0 ? -C / B : 0.0;
  }
  const double disc = B * B - 4.0 * A * C;
  if (disc < 0.0) return std::max(0.0, -B / (2.0 * A));
  // Numerically stable roots: q = -(B + sign(B) sqrt(disc)) / 2, roots q/A and C/q.
  const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
  double best = std::numeric_limits<double>::infinity();
  for (double root : {q / A, q != 0.0 ? C / q : std::numeric_limits<double>::infinity()}) {
    if (root >= 0.0 && root < best) best = root;
  }
  return std::isfinite(best) ? best : 0.0;
}

InverseResult inverse_pressure(const TendonSpringParams& p, double force_N, double eps, double max_pressure_Pa) noexcept {
  if (!std::isfinite(eps)) return {0.0, InverseStatus::kInvalidInput};
  if (!(force_N > 0.0) || !std::isfinite(force_N)) return {0.0, InverseStatus::kNoForce};
  const double g = gain_N_per_Pa(p, eps + p.eps0 + force_N / p.k_N);
  if (!(g > p.min_gain_N_per_Pa)) return {max_pressure_Pa, InverseStatus::kUnreachable};
  const double pressure_Pa = force_N / g;
  if (pressure_Pa > max_pressure_Pa) return {max_pressure_Pa, InverseStatus::kSaturated};
  return {pressure_Pa, InverseStatus::kOk};
}

}  // namespace peha::models
