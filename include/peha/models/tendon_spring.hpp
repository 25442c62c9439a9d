#pragma once
/// \file
/// The controller's PAM force model: the Tendon-spring model (docs/models.md, paper §IV-B).
///
///     F = P * g(u),  g(u) = a*u^2 + b*u + c,  u = eps + eps0 + F/k
///
/// `eps` is the contraction computed from the joint angle with a rigid wire; `u` is the muscle's own
/// contraction once the wire's stretch (F/k) and initial slack (eps0) are accounted for. Pressures are
/// gauge pressures in Pa, forces in N, contractions dimensionless ((L0 - L) / L0).
///
/// Both directions are total functions: they return a finite, documented value for every input.

namespace peha::models {

/// The five calibrated parameters lambda = (a, b, c, k, eps0).
struct TendonSpringParams {
  double a_N_per_Pa = 0.0;         ///< quadratic coefficient of g(u), N/Pa
  double b_N_per_Pa = 0.0;         ///< linear coefficient of g(u), N/Pa
  double c_N_per_Pa = 0.0;         ///< g(0), force per pressure at zero contraction, N/Pa
  double k_N = 1.0;                ///< wire stiffness, N per unit contraction ratio (> 0)
  double eps0 = 0.0;               ///< initial wire slack expressed as a contraction ratio
  /// g(u) below this is treated as "the muscle cannot pull here", N/Pa. Keeps P* = F/g finite.
  double min_gain_N_per_Pa = 1e-6;
};

/// g(u) = a*u^2 + b*u + c in N/Pa. For a > 0 the parabola turns up again past its vertex
/// u_v = -b/(2a), which no muscle does: there g is held at g(u_v) (non-increasing continuation).
double gain_N_per_Pa(const TendonSpringParams& p, double muscle_contraction) noexcept;

/// Why the inverse model returned what it returned.
enum class InverseStatus {
  kOk,           ///< P* = F*/g(u) within [0, max_pressure_Pa]
  kNoForce,      ///< F* <= 0 (or not finite): a muscle cannot push, P* = 0
  kSaturated,    ///< the exact P* exceeds max_pressure_Pa: P* = max_pressure_Pa
  kUnreachable,  ///< g(u) <= min_gain: the muscle cannot pull at that contraction, P* = max_pressure_Pa
  kInvalidInput  ///< eps not finite: P* = 0
};

struct InverseResult {
  double pressure_Pa = 0.0;
  InverseStatus status = InverseStatus::kOk;
};

/// Forward model (P, eps) -> F in N.
/// Substitutes u = eps + eps0 + F/k and solves the quadratic in F for its smallest root >= 0.
/// Edge behaviour: P <= 0 or not finite -> 0; g(eps + eps0) <= 0 (the muscle cannot pull at zero
/// load) -> 0; past the vertex of g (see gain_N_per_Pa) -> P * g(u_v). The residual P*g(u(F)) - F
/// is then non-increasing in F, so the root is unique.
double forward_force_N(const TendonSpringParams& p, double pressure_Pa, double eps) noexcept;

/// Inverse model (F*, eps) -> P* in closed form: P* = F* / g(eps + eps0 + F*/k), see InverseStatus
/// for every edge. Never NaN; always within [0, max_pressure_Pa], the ceiling the caller has (the
/// joint's supply: models::JointModel::supply_pressure_Pa).
InverseResult inverse_pressure(const TendonSpringParams& p, double force_N, double eps, double max_pressure_Pa) noexcept;

}  // namespace peha::models
