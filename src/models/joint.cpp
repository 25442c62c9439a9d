#include "peha/models/joint.hpp"

#include <algorithm>
#include <cmath>

namespace peha::models {

double force_ceiling_N(const MuscleModel& m) noexcept { return std::min(m.max_force_N, kMaxPamForce_N); }

InverseResult muscle_pressure(const MuscleModel& m, double force_N, double eps, double supply_pressure_Pa) noexcept {
  InverseResult inv = inverse_pressure(m.pam, force_N, eps, supply_pressure_Pa);
  // The learned residual corrects the parametric inverse where that is defined: p* = g^-1(F*) + f(eps, F*).
  const double residual = m.residual && inv.status == InverseStatus::kOk ? m.residual->pressure_Pa(eps, force_N) : 0.0;
  inv.pressure_Pa = std::clamp(inv.pressure_Pa + (std::isfinite(residual) ? residual : 0.0), 0.0, supply_pressure_Pa);
  return inv;
}

double rigid_contraction(const MuscleModel& m, double r0, int side, double angle_rad) noexcept {
  return m.contraction_at_zero_angle + side * r0 * angle_rad / m.rest_length_m;
}

double wire_velocity_mps(double r0, int side, double joint_velocity_radps) noexcept {
  return side * r0 * joint_velocity_radps;
}

double joint_torque_Nm(double r0, double f1, double f2, double motor_torque_Nm) noexcept {
  return (f1 - f2) * r0 + motor_torque_Nm;
}

}  // namespace peha::models
