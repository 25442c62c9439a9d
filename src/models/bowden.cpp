#include "peha/models/bowden.hpp"

#include <algorithm>
#include <cmath>

namespace peha::models {

double muscle_to_joint_ratio(const BowdenParams& p, double v) noexcept {
  if (!std::isfinite(v)) v = 0.0;
  const double s = std::tanh(0.5 * p.sigmoid_gain_s_per_m * v);  // == 2*sigma(alpha v) - 1
  return std::exp(p.friction_coefficient * p.wrap_angle_rad * s);
}

double muscle_force_for_joint_N(const BowdenParams& p, double joint_force_N, double v) noexcept {
  return joint_force_N * muscle_to_joint_ratio(p, v);
}

double joint_force_from_loadcell_N(const BowdenParams& p, double loadcell_N, double v) noexcept {
  return loadcell_N / muscle_to_joint_ratio(p, v);
}

BowdenParams sure_friction(const BowdenParams& p, double sure_fraction) noexcept {
  BowdenParams sure = p;
  sure.friction_coefficient = p.friction_coefficient * (std::isnan(sure_fraction) ? 0.0 : std::clamp(sure_fraction, 0.0, 1.0));
  return sure;
}

}  // namespace peha::models
