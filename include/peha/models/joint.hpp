#pragma once
/// \file
/// One PEHA joint as the controller models it: an antagonistic PAM pair pulling a pulley through
/// Bowden cables, plus an optional geared motor (docs/models.md, paper eq. 1).
///
/// Sign conventions: joint angle and torque are positive in the agonist's direction (the agonist
/// lifts against gravity). When the angle grows the agonist shortens (its contraction grows) and its
/// wire moves toward it (positive wire velocity for the agonist, negative for the antagonist).

#include "peha/models/bowden.hpp"
#include "peha/models/tendon_spring.hpp"

#include <limits>
#include <memory>
#include <string>

namespace peha::models {

/// Safety ceiling of any PAM force: the 1.7 mm inner wire broke at 2250 N (docs/models.md), 11 % margin.
inline constexpr double kMaxPamForce_N = 2000.0;

/// A learned correction of the inverse model's pressure (docs/spgp.md: p* = g^-1(F*) + f(eps, F*)).
/// Implementations must be noexcept, allocation-free and O(small) per call: they run in the loop.
class PressureResidual {
 public:
  virtual ~PressureResidual() = default;
  /// Pressure to add to the parametric inverse at rigid-wire contraction `eps` and force `force_N`, Pa.
  virtual double pressure_Pa(double eps, double force_N) const noexcept = 0;
  /// pressure_Pa at (eps, force_a_N) and (eps, force_b_N) into out[0] and out[1]: the same values
  /// as two calls (an implementation may share the work of the common contraction).
  virtual void pressure_pair_Pa(double eps, double force_a_N, double force_b_N, double out[2]) const noexcept {
    out[0] = pressure_Pa(eps, force_a_N);
    out[1] = pressure_Pa(eps, force_b_N);
  }
  /// Bounds every value of pressure_Pa lies in, Pa (default: none known, -inf..+inf). Lets a caller
  /// that only asks whether the corrected pressure reaches 0 or the supply skip the evaluation.
  virtual void bounds_Pa(double& lo, double& hi) const noexcept {
    lo = -std::numeric_limits<double>::infinity();
    hi = std::numeric_limits<double>::infinity();
  }
};

/// One muscle of the pair, with its cable.
struct MuscleModel {
  std::string name;                     ///< e.g. "agonist"
  TendonSpringParams pam;               ///< force model (pressures in Pa)
  BowdenParams bowden;                  ///< cable friction model
  double rest_length_m = 0.4;           ///< muscle nominal length L0, m
  double contraction_at_zero_angle = 0; ///< rigid-wire contraction eps at joint angle 0
  double max_force_N = kMaxPamForce_N;  ///< this muscle's own ceiling (<= kMaxPamForce_N), N
  /// Optional calibrated residual (the SPGP); null = parametric model only.
  std::shared_ptr<const PressureResidual> residual;
  /// Its load cell's reading at zero force, N: the zero a calibration's recording measured with the
  /// muscle vented (its forces are true forces, not raw readings). The controllers subtract it from
  /// every reading when no start-up tare runs; 0 = the reading is the force.
  double loadcell_zero_N = 0.0;
};

/// Immutable model of a PEHA joint: the one joint set-up the controller and the limits layer share,
/// assembled once from the scenario (and, where given, a muscle calibration replaces `pam` and
/// `residual` of a muscle). Supply pressure and pretension live here and nowhere else.
struct JointModel {
  std::string name;
  double pulley_radius_m = 0.05;  ///< r0, m
  double supply_pressure_Pa = 0.8e6;  ///< the valves' supply: the ceiling of every pressure command, Pa (gauge)
  double pretension_N = 20.0;     ///< the least muscle force that keeps a wire taut (never slack), N
  MuscleModel agonist;            ///< muscle 1, pulls toward positive angles
  MuscleModel antagonist;         ///< muscle 2, pulls toward negative angles
  bool has_motor = true;
  double motor_max_torque_Nm = 2.5;  ///< motor rating at the joint (after the 35:1 gear), Nm
};

/// The force no command may ask of muscle `m`: its own ceiling, never above kMaxPamForce_N, N.
double force_ceiling_N(const MuscleModel& m) noexcept;

/// The one pressure model of a muscle, used by the allocation and by the limits layer alike: the
/// closed-form inverse Tendon-spring pressure for `force_N` at rigid-wire contraction `eps`, plus the
/// learned residual where the parametric inverse is defined (status kOk), clamped to [0, supply].
/// A non-finite residual counts as 0. noexcept, allocation-free.
InverseResult muscle_pressure(const MuscleModel& m, double force_N, double eps, double supply_pressure_Pa) noexcept;

/// muscle_pressure at `force_a_N` and `force_b_N` (the same contraction) into out[0] and out[1]:
/// the same results as two calls, with the residual evaluated for both in one pass when both
/// parametric inverses are defined.
void muscle_pressure_pair(const MuscleModel& m, double force_a_N, double force_b_N, double eps, double supply_pressure_Pa,
                          InverseResult out[2]) noexcept;

/// An interval [lo, hi] that muscle_pressure(m, force_N, eps, supply).pressure_Pa lies in, from the
/// parametric inverse and the residual's bounds only (the residual is not evaluated): lo == hi
/// without a residual or where the parametric inverse is not defined.
struct PressureInterval {
  double lo_Pa, hi_Pa;
};
PressureInterval muscle_pressure_interval(const MuscleModel& m, double force_N, double eps, double supply_pressure_Pa) noexcept;

/// Rigid-wire contraction of the agonist (+1) or antagonist (-1) at `angle_rad`.
/// eps = eps(0) + side * r0 * angle / L0.
double rigid_contraction(const MuscleModel& m, double pulley_radius_m, int side,
                         double angle_rad) noexcept;

/// Wire velocity (m/s, > 0 toward the muscle) of the agonist (+1) or antagonist (-1).
double wire_velocity_mps(double pulley_radius_m, int side, double joint_velocity_radps) noexcept;

/// Paper eq. (1): tau = (f1 - f2) * r0 + tau_motor, forces at the pulley in N, torque in Nm.
double joint_torque_Nm(double pulley_radius_m, double agonist_force_N, double antagonist_force_N,
                       double motor_torque_Nm) noexcept;

}  // namespace peha::models
