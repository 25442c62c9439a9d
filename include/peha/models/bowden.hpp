#pragma once
/// \file
/// Bowden cable friction compensation (docs/models.md).
///
/// The capstan law gives a force ratio exp(mu * psi) between the two ends of a wire sliding over a
/// total wrap angle psi. Its direction follows the wire's motion; a sigmoid of the wire velocity
/// makes it continuous:
///
///     F_pam = F_joint * exp(mu * psi * s(v)),  s(v) = 2*sigma(alpha*v) - 1 = tanh(alpha*v/2)
///
/// with v > 0 when the wire moves toward the muscle (the muscle shortens and must also overcome the
/// friction). At v = 0 the command is unchanged. The load cells sit on the muscle side, so the force
/// reaching the pulley is the load-cell force divided by the same factor.

namespace peha::models {

struct BowdenParams {
  double friction_coefficient = 0.0;  ///< mu, dimensionless Coulomb coefficient wire/housing
  double wrap_angle_rad = 0.0;        ///< psi, total bend angle of the housing, rad
  double sigmoid_gain_s_per_m = 100;  ///< alpha, s/m; larger narrows the insensitive band around v=0
};

/// Ratio F_pam / F_joint at wire velocity `wire_velocity_mps` (m/s, > 0 toward the muscle).
/// Always finite and > 0; ratio(v) * ratio(-v) == 1.
double muscle_to_joint_ratio(const BowdenParams& p, double wire_velocity_mps) noexcept;

/// Force the muscle must make so that `joint_force_N` reaches the pulley.
double muscle_force_for_joint_N(const BowdenParams& p, double joint_force_N,
                                double wire_velocity_mps) noexcept;

/// Force reaching the pulley when the muscle-side load cell reads `loadcell_N`.
double joint_force_from_loadcell_N(const BowdenParams& p, double loadcell_N,
                                   double wire_velocity_mps) noexcept;

/// The cable with only the friction the plant is sure to have: `friction_coefficient` times
/// `sure_fraction` (clamped to [0, 1]; NaN counts as 0). Compensating this much cannot inject
/// energy into the joint as long as the real cable has at least this friction (docs/models.md,
/// "Compensation that cannot destabilise"); 0 turns the velocity-dependent compensation off.
BowdenParams sure_friction(const BowdenParams& p, double sure_fraction) noexcept;

}  // namespace peha::models
