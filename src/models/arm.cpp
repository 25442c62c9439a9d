#include "peha/models/arm.hpp"

namespace peha::models {

ArmData::ArmData(const ArmModel& model)
    : R(model.joints.size(), Eigen::Matrix3d::Identity()),
      p(model.joints.size(), Eigen::Vector3d::Zero()),
      z(model.joints.size(), Eigen::Vector3d::UnitZ()),
      tau(Eigen::VectorXd::Zero(model.dof())),
      jacobian(Eigen::MatrixXd::Zero(3, model.dof())) {}

void forward_kinematics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept {
  Eigen::Matrix3d parent_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d parent_p = Eigen::Vector3d::Zero();
  for (int i = 0; i < model.dof(); ++i) {
    const ArmJoint& j = model.joints[static_cast<std::size_t>(i)];
    data.p[i] = parent_p + parent_R * j.offset_m;
    data.z[i] = parent_R * j.axis;  // the axis does not move under its own rotation
    data.R[i] = parent_R * Eigen::AngleAxisd(q[i], j.axis).toRotationMatrix();
    parent_R = data.R[i];
    parent_p = data.p[i];
  }
}

Eigen::Vector3d com_position(const ArmModel& model, const ArmData& data, int body) noexcept {
  const ArmBody& b = model.bodies[static_cast<std::size_t>(body)];
  return data.p[b.joint] + data.R[b.joint] * b.com_m;
}

void com_jacobian(const ArmModel& model, ArmData& data, int body) noexcept {
  const ArmBody& b = model.bodies[static_cast<std::size_t>(body)];
  const Eigen::Vector3d c = com_position(model, data, body);
  data.jacobian.setZero();
  // Serial chain: every joint up to the body's own moves it; J_k = z_k x (c - p_k).
  for (int k = 0; k <= b.joint; ++k) data.jacobian.col(k) = data.z[k].cross(c - data.p[k]);
}

const Eigen::VectorXd& gravity_torque(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept {
  forward_kinematics(model, data, q);
  data.tau.setZero();
  for (int b = 0; b < static_cast<int>(model.bodies.size()); ++b) {
    com_jacobian(model, data, b);
    // Holding torque = J^T (m g e_z): the negative of gravity's generalised force.
    data.tau.noalias() += data.jacobian.row(2).transpose() * (model.bodies[static_cast<std::size_t>(b)].mass_kg * model.gravity_mps2);
  }
  return data.tau;
}

}  // namespace peha::models
