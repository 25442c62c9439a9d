#include "peha/models/arm.hpp"

namespace peha::models {

ArmData::ArmData(const ArmModel& model)
    : R(model.joints.size(), Eigen::Matrix3d::Identity()),
      p(model.joints.size(), Eigen::Vector3d::Zero()),
      z(model.joints.size(), Eigen::Vector3d::UnitZ()),
      tau(Eigen::VectorXd::Zero(model.dof())),
      jacobian(Eigen::MatrixXd::Zero(3, model.dof())),
      omega(model.joints.size()),
      alpha(model.joints.size()),
      accel(model.joints.size()),
      force(model.bodies.size()),
      moment(model.bodies.size()) {}

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

const Eigen::VectorXd& inverse_dynamics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& qd, const Eigen::VectorXd& qdd) noexcept {
  forward_kinematics(model, data, q);
  // Forward pass: kinematics of each joint frame. Gravity enters as an upward acceleration of the
  // base, so every body's inertial force already carries its weight.
  Eigen::Vector3d w = Eigen::Vector3d::Zero(), dw = Eigen::Vector3d::Zero();
  Eigen::Vector3d a(0.0, 0.0, model.gravity_mps2);
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (int i = 0; i < model.dof(); ++i) {
    const Eigen::Vector3d r = data.p[i] - origin;  // previous frame's origin -> this one
    a += dw.cross(r) + w.cross(w.cross(r));
    dw += data.z[i] * qdd[i] + w.cross(data.z[i] * qd[i]);
    w += data.z[i] * qd[i];
    data.omega[i] = w;
    data.alpha[i] = dw;
    data.accel[i] = a;
    origin = data.p[i];
  }
  // Each body's net force and moment about its COM (Newton and Euler, world frame).
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const ArmBody& body = model.bodies[b];
    const int j = body.joint;
    const Eigen::Vector3d rc = data.R[j] * body.com_m;
    const Eigen::Vector3d ac = data.accel[j] + data.alpha[j].cross(rc) + data.omega[j].cross(data.omega[j].cross(rc));
    const Eigen::Matrix3d I = data.R[j] * body.inertia_kgm2 * data.R[j].transpose();
    data.force[b] = body.mass_kg * ac;
    data.moment[b] = I * data.alpha[j] + data.omega[j].cross(I * data.omega[j]);
  }
  // Backward pass: joint i carries every body outboard of it; its torque is the moment about its
  // axis. A serial chain: body b is outboard of joint i when b's joint >= i.
  for (int i = 0; i < model.dof(); ++i) {
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (std::size_t b = 0; b < model.bodies.size(); ++b) {
      if (model.bodies[b].joint < i) continue;
      const Eigen::Vector3d c = data.p[model.bodies[b].joint] + data.R[model.bodies[b].joint] * model.bodies[b].com_m;
      moment += data.moment[b] + (c - data.p[i]).cross(data.force[b]);
    }
    data.tau[i] = data.z[i].dot(moment);
  }
  return data.tau;
}

}  // namespace peha::models
