#pragma once
/// \file
/// Private to src/sim: the plant muscle law (include/peha/sim/plant_muscle.hpp) evaluated at one
/// pressure, with the parameters' clamps and the pressure's terms derived once. The plant's wire
/// equilibrium (PehaJointPlant::solve_muscle) evaluates the law ~4-5 times per muscle and physics
/// step at one chamber pressure; sim::force_N and sim::static_force_N are this same code, so the
/// figures are bit for bit those of the public functions (same operations in the same order).

#include "peha/sim/plant_muscle.hpp"

#include <algorithm>
#include <cmath>

namespace peha::sim::detail {

inline constexpr double kPressureUnit_Pa = 1.0e6;  // beta is "per MPa"
// Floors for the divisors, so that even a hand-made (unvalidated) struct cannot produce NaN.
inline constexpr double kTiny = 1e-12;

/// log(1 + exp(x)) without overflow. From x > 34 on, log1p(exp(-x)) < 1.8e-15 is less than half an
/// ulp of x (3.55e-15 for x in [32, 64)), so the sum rounds to x itself: returned without the exp
/// and log1p, bit for bit the same result (the plant's stretched muscles are there half the time).
inline double softplus(double x) noexcept {
  if (x > 34.0) return x;
  return std::max(x, 0.0) + std::log1p(std::exp(-std::abs(x)));
}

/// tanh(x), skipping libm where its result is +-1 anyway: from |x| = 19.06 on 1 - tanh|x| is below
/// half an ulp of 1 and glibc's tanh returns exactly +-1 (checked over 2e7 random arguments in
/// [20, 30]); its own shortcut only starts at 22. A NaN goes to std::tanh.
inline double saturating_tanh(double x) noexcept {
  if (std::abs(x) >= 20.0) return x > 0.0 ? 1.0 : -1.0;
  return std::tanh(x);
}

/// The law at one pressure (see plant_muscle.hpp for the symbols).
struct MuscleLawAtPressure {
  bool nan_pressure;
  double q_Pa;             ///< q(P) at the clamped pressure
  double um, w, c, kappa;  ///< clamped gain shape
  double gain_scaled;      ///< g0 * (1 + kappa)
  double ue, uk;           ///< rubber scale and knee
  double elastic_force_N, elastic_stiffness_N;
  double delta;            ///< threshold smoothing
  double h, rate_scale;    ///< hysteresis

  MuscleLawAtPressure(const PlantMuscleParams& p, double pressure_Pa) noexcept
      : nan_pressure(std::isnan(pressure_Pa)),
        um(std::max(p.gain_zero_contraction, kTiny)),
        w(std::max(p.gain_smoothing_contraction, kTiny)),
        c(std::clamp(p.gain_quadratic_fraction, 0.0, 1.0)),
        kappa(std::max(p.gain_saturation, 0.0)),
        gain_scaled(p.gain_N_per_Pa * (1.0 + kappa)),
        ue(std::max(p.elastic_contraction_scale, kTiny)),
        uk(p.elastic_knee_contraction),
        elastic_force_N(p.elastic_force_N),
        elastic_stiffness_N(p.elastic_stiffness_N),
        delta(std::max(p.threshold_smoothing_N, kTiny)),
        h(std::clamp(p.hysteresis_fraction, 0.0, 1.0)),
        rate_scale(std::max(p.hysteresis_rate_scale_1ps, kTiny)) {
    const double P = std::clamp(pressure_Pa, 0.0, std::max(p.max_pressure_Pa, 0.0));
    q_Pa = P * (1.0 + p.pressure_curvature_per_MPa * P / kPressureUnit_Pa);
  }

  /// z(P, u) at a clamped contraction u: the gain (d ~ 1 - u/u_m rounded off to 0 beyond u_m, s(d),
  /// g saturating in s) times q(P), plus the rubber (exponential, continued along its tangent below
  /// the knee).
  double z_N(double u) const noexcept {
    const double x = (um - u) / w;
    const double d = w * softplus(x) / um;
    const double s = ((1.0 - c) + c * d) * d;
    const double den = 1.0 + kappa * s;
    const double g = gain_scaled * s / den;
    double E = 0.0;
    if (u >= uk) {
      E = std::exp(-u / ue);
    } else {
      const double Ek = std::exp(-uk / ue);
      E = Ek * (1.0 - (u - uk) / ue);
    }
    const double f_el = elastic_force_N * (E - 1.0) - elastic_stiffness_N * u;
    return g * q_Pa + f_el;
  }

  /// sim::static_force_N at this pressure.
  double static_force_N(double contraction) const noexcept {
    if (nan_pressure || std::isnan(contraction)) return 0.0;
    const double u = std::clamp(contraction, kMinContraction, kMaxContraction);
    return delta * softplus(z_N(u) / delta);
  }

  /// The hysteresis factor 1 - h tanh(rate / r_h) (a NaN rate counts as 0).
  double hysteresis_factor(double contraction_rate_1ps) const noexcept {
    const double rate = std::isnan(contraction_rate_1ps) ? 0.0 : contraction_rate_1ps;
    return 1.0 - h * saturating_tanh(rate / rate_scale);
  }

  /// sim::force_N at this pressure: static_force_N(contraction) * hysteresis_factor(rate).
  double force_N(double contraction, double contraction_rate_1ps) const noexcept {
    const double factor = hysteresis_factor(contraction_rate_1ps);
    return static_force_N(contraction) * factor;
  }
};

}  // namespace peha::sim::detail
