#include "peha/models/bowden.hpp"

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

}  // namespace peha::models
