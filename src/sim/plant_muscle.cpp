#include "peha/sim/plant_muscle.hpp"

#include "plant_muscle_law.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace peha::sim {
namespace {

using detail::kPressureUnit_Pa;
using detail::kTiny;
using detail::softplus;

/// 1 / (1 + exp(-x)) without overflow; the derivative of softplus.
double sigmoid(double x) noexcept {
  if (x >= 0.0) return 1.0 / (1.0 + std::exp(-x));
  const double e = std::exp(x);
  return e / (1.0 + e);
}

/// z(P, u) and dz/du at clamped inputs.
struct Inner {
  double z_N;
  double dz_du_N;  ///< 0 unless asked for
};

/// z(P, u), and dz/du when kDerivative (the force alone is detail::MuscleLawAtPressure's, in
/// plant_muscle_law.hpp; the two compute z by the same operations).
template <bool kDerivative>
Inner inner(const PlantMuscleParams& p, double pressure_Pa, double u) noexcept {
  const double P = std::clamp(pressure_Pa, 0.0, std::max(p.max_pressure_Pa, 0.0));
  const double q_Pa = P * (1.0 + p.pressure_curvature_per_MPa * P / kPressureUnit_Pa);

  // Gain: d ~ 1 - u/u_m, rounded off to 0 beyond u_m; s(d) increasing for d > 0 because c is in
  // [0, 1]; g saturating in s (g(d=1) = g0).
  const double um = std::max(p.gain_zero_contraction, kTiny);
  const double w = std::max(p.gain_smoothing_contraction, kTiny);
  const double x = (um - u) / w;
  const double d = w * softplus(x) / um;
  const double c = std::clamp(p.gain_quadratic_fraction, 0.0, 1.0);
  const double s = ((1.0 - c) + c * d) * d;
  const double kappa = std::max(p.gain_saturation, 0.0);
  const double den = 1.0 + kappa * s;
  const double g = p.gain_N_per_Pa * (1.0 + kappa) * s / den;

  // Rubber: exponential, continued along its tangent below the knee to keep the stiffness bounded.
  const double ue = std::max(p.elastic_contraction_scale, kTiny);
  const double uk = p.elastic_knee_contraction;
  double E = 0.0;
  [[maybe_unused]] double dE_du = 0.0;
  if (u >= uk) {
    E = std::exp(-u / ue);
    dE_du = -E / ue;
  } else {
    const double Ek = std::exp(-uk / ue);
    E = Ek * (1.0 - (u - uk) / ue);
    dE_du = -Ek / ue;
  }
  const double f_el = p.elastic_force_N * (E - 1.0) - p.elastic_stiffness_N * u;
  if constexpr (!kDerivative) {
    return {g * q_Pa + f_el, 0.0};
  } else {
    const double dd_du = -sigmoid(x) / um;
    const double ds_dd = (1.0 - c) + 2.0 * c * d;
    const double dg_ds = p.gain_N_per_Pa * (1.0 + kappa) / (den * den);
    const double df_el_du = p.elastic_force_N * dE_du - p.elastic_stiffness_N;
    return {g * q_Pa + f_el, dg_ds * ds_dd * dd_du * q_Pa + df_el_du};
  }
}

}  // namespace

PlantMuscleParams read_plant_muscle(config::Map& map) {
  PlantMuscleParams p;
  p.name = map.string("name");
  p.gain_N_per_Pa = map.number("gain_N_per_Pa", {1e-6, 1.0});
  p.gain_saturation = map.number("gain_saturation", {0.0, 100.0});
  p.gain_quadratic_fraction = map.number("gain_quadratic_fraction", {0.0, 1.0});
  p.gain_zero_contraction = map.number("gain_zero_contraction", {0.05, 1.0});
  p.gain_smoothing_contraction = map.number("gain_smoothing_contraction", {1e-3, 0.5});
  p.pressure_curvature_per_MPa = map.number("pressure_curvature_per_MPa", {-0.45, 2.0});
  p.elastic_force_N = map.number("elastic_force_N", {0.0, 1e5});
  // u_e >= 0.002 with u_k >= -0.3 bounds exp(-u_k/u_e) by e^150: large but finite.
  p.elastic_contraction_scale = map.number("elastic_contraction_scale", {0.002, 1.0});
  p.elastic_stiffness_N = map.number("elastic_stiffness_N", {0.0, 1e6});
  p.elastic_knee_contraction = map.number("elastic_knee_contraction", {-0.3, 0.0});
  p.threshold_smoothing_N = map.number("threshold_smoothing_N", {0.01, 1000.0});
  p.max_pressure_Pa = map.number("max_pressure_Pa", {1e5, 2e6});
  p.hysteresis_fraction = map.number("hysteresis_fraction", {0.0, 0.5});
  p.hysteresis_rate_scale_1ps = map.number("hysteresis_rate_scale_1ps", {1e-4, 100.0});
  // dq/dP = 1 + 2*beta*P/1MPa must stay > 0 up to the clamp, else F would fall with rising P.
  const double slope_at_max =
      1.0 + 2.0 * p.pressure_curvature_per_MPa * p.max_pressure_Pa / kPressureUnit_Pa;
  if (!(slope_at_max > 0.0)) {
    map.fail("pressure_curvature_per_MPa",
             fmt::format("force would decrease with pressure below max_pressure_Pa = {} "
                         "(need 1 + 2*beta*P_max/1MPa > 0, found {})",
                         p.max_pressure_Pa, slope_at_max));
  }
  map.finish();
  return p;
}

PlantMuscleParams load_plant_muscle(const std::filesystem::path& yaml_file) {
  config::Map root = config::Document::load_file(yaml_file).root();
  return read_plant_muscle(root);
}

double static_force_N(const PlantMuscleParams& p, double pressure_Pa, double contraction) noexcept {
  return detail::MuscleLawAtPressure(p, pressure_Pa).static_force_N(contraction);
}

double static_force_dcontraction_N(const PlantMuscleParams& p, double pressure_Pa,
                                   double contraction) noexcept {
  if (std::isnan(pressure_Pa) || std::isnan(contraction)) return 0.0;
  if (contraction < kMinContraction || contraction > kMaxContraction) return 0.0;
  const double delta = std::max(p.threshold_smoothing_N, kTiny);
  const Inner in = inner<true>(p, pressure_Pa, contraction);
  return sigmoid(in.z_N / delta) * in.dz_du_N;
}

double force_ceiling_N(const PlantMuscleParams& p) noexcept {
  const double h = std::clamp(p.hysteresis_fraction, 0.0, 1.0);
  return static_force_N(p, p.max_pressure_Pa, p.elastic_knee_contraction) * (1.0 + h);
}

double force_N(const PlantMuscleParams& p, double pressure_Pa, double contraction,
               double contraction_rate_1ps) noexcept {
  return detail::MuscleLawAtPressure(p, pressure_Pa).force_N(contraction, contraction_rate_1ps);
}

}  // namespace peha::sim
