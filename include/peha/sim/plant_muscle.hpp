#pragma once
/// \file
/// The simulated plant's muscle force law (docs/simulator.md): a static force map F(P, u) of a Festo DMSP
/// fluidic muscle fitted to the real datasheet maps, plus a rate-dependent hysteresis factor.
/// This is the truth the controller never sees; it is deliberately richer than the controller's
/// Tendon-spring model F = P*g(u) (models/tendon_spring.hpp). See docs/plant-muscle.md.
///
///     F_static(P, u) = delta * softplus(z / delta)                    (never negative, C-infinity)
///     z(P, u)        = g(u) * q(P) + f_el(u)                          (force before "cannot push")
///     q(P)           = P * (1 + beta * P / 1 MPa)                     (nonlinearity in pressure)
///     g(u)           = g0 * (1 + kappa) * s / (1 + kappa * s)         (gain, N/Pa, saturating)
///     s(u)           = (1 - c) * d + c * d^2                          (linear..quadratic in d)
///     d(u)           = w * softplus((u_m - u) / w) / u_m              (~ 1 - u/u_m, -> 0 past u_m)
///     f_el(u)        = k_e * (E(u) - 1) - k_l * u                     (rubber, N)
///     E(u)           = exp(-u / u_e) for u >= u_k, else continued linearly (C1) below the knee u_k
///     F(P, u, du/dt) = F_static * (1 - h * tanh((du/dt) / r_h))       (hysteresis)
///
/// f_el < 0 for u > 0 is the pressure threshold: the muscle makes no force until g*q exceeds the
/// rubber's resistance to contraction. f_el > 0 for u < 0 is the large passive force when the
/// muscle is stretched, also at P = 0. The end effect (force -> 0 at the maximum contraction) comes
/// from the gain falling towards 0 at u_m while the rubber keeps resisting: the force ends where
/// g*q = -f_el, at a contraction that grows with pressure (about 0.29..0.35 for DMSP-40 at
/// 0.3..0.8 MPa, 0.13..0.25 for DMSP-10).
///
/// Units: pressures are gauge pressures in Pa, forces in N, contraction u = (L0 - L) / L0
/// (dimensionless, negative = stretched), contraction rate in 1/s (> 0 while the muscle shortens).
///
/// Input handling (all functions are total and noexcept, no allocation): the pressure is clamped
/// to [0, max_pressure_Pa] and the contraction to [kMinContraction, kMaxContraction]; a NaN
/// pressure or contraction gives F = 0 and dF/du = 0; a NaN rate counts as 0. For parameters accepted by
/// `read_plant_muscle` every result is finite and F >= 0.

#include "peha/config/reader.hpp"

#include <filesystem>
#include <string>

namespace peha::sim {

/// Contractions below this are treated as this value (a muscle stretched to twice its length has
/// long torn); F is constant and dF/du = 0 beyond.
inline constexpr double kMinContraction = -1.0;
/// Contractions above this are treated as this value (a muscle cannot shorten to nothing).
inline constexpr double kMaxContraction = 1.0;

/// Parameters of the plant muscle law. The defaults are a rounded DMSP-40 fit so that a
/// default-constructed value is usable; the generated configs/plant/*.yaml are authoritative.
struct PlantMuscleParams {
  std::string name = "DMSP-40";  ///< muscle type, for logs only
  /// g0: force per gauge pressure at zero contraction (d = 1), N/Pa. > 0.
  double gain_N_per_Pa = 0.0104;
  /// kappa: saturation of the gain in s (0 = no saturation; larger = flatter when stretched). >= 0.
  double gain_saturation = 0.44;
  /// c: shape of s(d) between linear (0) and quadratic (1, Chou-Hannaford-like) in d. In [0, 1].
  double gain_quadratic_fraction = 0.99;
  /// u_m: contraction at which d, and so the gain, reaches zero. Not the maximum contraction: the
  /// force ends earlier, where the gain no longer overcomes the rubber.
  double gain_zero_contraction = 0.43;
  /// w: width, in contraction, of the softplus that rounds d off to 0 near u_m.
  double gain_smoothing_contraction = 0.03;
  /// beta: relative change of force per pressure per MPa: q(P) = P * (1 + beta * P / 1 MPa).
  /// Must keep dq/dP > 0 on [0, max_pressure_Pa] (checked by the reader).
  double pressure_curvature_per_MPa = -0.025;
  /// k_e: scale of the exponential rubber force, N (f_el -> -k_e - k_l*u when contracted).
  double elastic_force_N = 464.0;
  /// u_e: contraction scale of the exponential rubber force (smaller = stiffer passive end).
  double elastic_contraction_scale = 0.0296;
  /// k_l: linear rubber stiffness, N per unit contraction. >= 0.
  double elastic_stiffness_N = 0.0;
  /// u_k: below this contraction (stretched further than the data reach) the exponential continues
  /// linearly with its slope at u_k, so the passive stiffness stays bounded. <= 0.
  double elastic_knee_contraction = -0.05;
  /// delta: sharpness of the softplus that maps z to F >= 0, N. F(z = 0) = delta * ln 2.
  double threshold_smoothing_N = 35.0;
  /// Pressures are clamped to [0, max_pressure_Pa] before use, Pa.
  double max_pressure_Pa = 1.0e6;
  /// h: half-width of the hysteresis loop as a fraction of F_static (loop width 2h). In [0, 0.5].
  double hysteresis_fraction = 0.05;
  /// r_h: contraction rate at which the hysteresis reaches tanh(1) = 76 % of its full size, 1/s.
  double hysteresis_rate_scale_1ps = 0.02;
};

/// Reads a plant muscle law from `map` and calls `map.finish()`. Keys: `name`, and one per numeric
/// field of PlantMuscleParams with the same name. Every number is range-checked; unknown keys, a
/// missing key, or a pressure curvature that would make F decrease with P throw `config::Error`.
PlantMuscleParams read_plant_muscle(config::Map& map);

/// Loads a whole YAML file (the top-level mapping is the law) with `read_plant_muscle`.
PlantMuscleParams load_plant_muscle(const std::filesystem::path& yaml_file);

/// Static force F_static(P, u) in N: >= 0, finite, C1 (C-infinity inside the clamp ranges except at
/// the knee u_k, where it is C1), strictly decreasing in u and non-decreasing in P.
double static_force_N(const PlantMuscleParams& p, double pressure_Pa, double contraction) noexcept;

/// Analytic partial derivative dF_static/du in N per unit contraction (<= 0). Zero outside the
/// contraction clamp range and for NaN inputs.
double static_force_dcontraction_N(const PlantMuscleParams& p, double pressure_Pa,
                                   double contraction) noexcept;

/// The most force the law gives where it was fitted, N: at max_pressure_Pa, stretched to
/// elastic_knee_contraction (beyond it the rubber is extrapolated) and being stretched (hysteresis
/// +h). A reading above it is not this muscle's force (a unit mistake or a load-cell glitch).
double force_ceiling_N(const PlantMuscleParams& p) noexcept;

/// Force with hysteresis in N: F_static * (1 - h * tanh(rate / r_h)). Lower while the muscle
/// contracts (rate > 0), higher while it is stretched (rate < 0); >= 0 and finite.
double force_N(const PlantMuscleParams& p, double pressure_Pa, double contraction,
               double contraction_rate_1ps) noexcept;

}  // namespace peha::sim
