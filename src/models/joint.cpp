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

void muscle_pressure_pair(const MuscleModel& m, double force_a_N, double force_b_N, double eps, double supply_pressure_Pa,
                          InverseResult out[2]) noexcept {
  out[0] = inverse_pressure(m.pam, force_a_N, eps, supply_pressure_Pa);
  out[1] = inverse_pressure(m.pam, force_b_N, eps, supply_pressure_Pa);
  double residual[2] = {0.0, 0.0};
  if (m.residual) {
    const bool a = out[0].status == InverseStatus::kOk, b = out[1].status == InverseStatus::kOk;
    if (a && b) {
      m.residual->pressure_pair_Pa(eps, force_a_N, force_b_N, residual);
    } else if (a) {
      residual[0] = m.residual->pressure_Pa(eps, force_a_N);
    } else if (b) {
      residual[1] = m.residual->pressure_Pa(eps, force_b_N);
    }
  }
  for (int i = 0; i < 2; ++i) {
    out[i].pressure_Pa = std::clamp(out[i].pressure_Pa + (std::isfinite(residual[i]) ? residual[i] : 0.0), 0.0, supply_pressure_Pa);
  }
}

PressureInterval muscle_pressure_interval(const MuscleModel& m, double force_N, double eps, double supply_pressure_Pa) noexcept {
  const InverseResult inv = inverse_pressure(m.pam, force_N, eps, supply_pressure_Pa);
  double lo = 0.0, hi = 0.0;  // a non-finite residual counts as 0: 0 is always possible
  if (m.residual && inv.status == InverseStatus::kOk) {
    m.residual->bounds_Pa(lo, hi);
    lo = std::min(lo, 0.0);
    hi = std::max(hi, 0.0);
  }
  return {std::clamp(inv.pressure_Pa + lo, 0.0, supply_pressure_Pa), std::clamp(inv.pressure_Pa + hi, 0.0, supply_pressure_Pa)};
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
