#pragma once
/// \file
/// The gravity torque of a serial arm as a linear function of its mass parameters (the standard
/// gravity regressor, docs/identification.md): tau_g(q) = Y(q) theta.
///
/// Per joint frame j, four parameters: the mass m_j (kg) of everything rigidly attached to frame j
/// and its first moment h_j = sum_b m_b c_b (kg m, a 3-vector in frame j, c_b the body's COM). With
/// p_j, R_j frame j's world origin and orientation, z_i joint i's world axis and e_z world up, the
/// torque that holds the arm (the negative of gravity's generalised force) is
///
///     tau_i = g e_z . sum_{j >= i} z_i x ( m_j (p_j - p_i) + R_j h_j )
///
/// which is linear in (m_j, h_j): column 4j of Y holds g e_z.(z_i x (p_j - p_i)), columns 4j+1..3 hold
/// g e_z.(z_i x R_j e_k). The parameter vector has 4 x dof entries, frame by frame:
/// [m_0, h_0x, h_0y, h_0z, m_1, ...]. Not every combination is identifiable from joint torques
/// (e.g. h_y of a frame whose axis is y never enters); calibration/gravity_identification finds the ones that are.

#include "peha/models/arm.hpp"

#include <Eigen/Dense>

#include <string>

namespace peha::models {

constexpr int kGravityParametersPerFrame = 4;  ///< m (kg), h_x, h_y, h_z (kg m)

/// Number of parameters of `model`: 4 per joint frame.
inline int gravity_parameter_count(const ArmModel& model) noexcept { return kGravityParametersPerFrame * model.dof(); }

/// The parameters of `model`'s bodies: per frame the summed mass and first moment.
Eigen::VectorXd gravity_parameters(const ArmModel& model);

/// Name of parameter k, e.g. "R_SFE.mass_kg", "R_EFE.hx_kgm".
std::string gravity_parameter_name(const ArmModel& model, int k);

/// The regressor Y (dof x 4 dof, Nm per parameter unit) at angles `q` (rad) into `Y`, which must be
/// sized already (`Eigen::MatrixXd(model.dof(), gravity_parameter_count(model))`). Uses model's
/// kinematics only (joints, gravity), not its bodies. noexcept, allocation-free.
void gravity_regressor(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q, Eigen::MatrixXd& Y) noexcept;

/// `model` with its bodies replaced by parameters `theta`: one body per frame with mass m_j, COM
/// h_j / m_j and the original bodies' inertia about that COM (parallel-axis theorem), so that
/// gravity_torque() of the result is Y(q) theta exactly and inverse dynamics keeps a plausible inertia.
/// Throws std::invalid_argument if a frame has a first moment but a mass <= 0 (no body can have it).
ArmModel with_gravity_parameters(const ArmModel& model, const Eigen::VectorXd& theta);

}  // namespace peha::models
