#include "peha/models/arm.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

namespace peha::models {

void check_tree(const ArmModel& model) {
  for (int i = 0; i < model.dof(); ++i) {
    const ArmJoint& j = model.joints[static_cast<std::size_t>(i)];
    if (j.parent == kWorldParent || j.parent == kPreviousJoint) continue;
    if (j.parent < 0 || j.parent >= i) {
      throw std::invalid_argument(fmt::format("arm: joint '{}' (index {}) names parent {}; a parent must be a joint listed "
                                              "before it ({} = the world, {} = the joint before)",
                                              j.name, i, j.parent, kWorldParent, kPreviousJoint));
    }
  }
  for (const ArmBody& b : model.bodies) {
    if (b.joint < 0 || b.joint >= model.dof()) {
      throw std::invalid_argument(
          fmt::format("arm: body '{}' hangs on joint {} of a {}-joint model", b.name, b.joint, model.dof()));
    }
  }
}

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
      moment(model.bodies.size()),
      subtree_mass_kg(model.joints.size(), 0.0),
      subtree_first_moment_kgm(model.joints.size(), Eigen::Vector3d::Zero()),
      joint_force(model.joints.size(), Eigen::Vector3d::Zero()),
      joint_moment(model.joints.size(), Eigen::Vector3d::Zero()) {
  check_tree(model);
}

void forward_kinematics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept {
  for (int i = 0; i < model.dof(); ++i) {
    const ArmJoint& j = model.joints[static_cast<std::size_t>(i)];
    const int parent = model.parent(i);
    if (parent < 0) {
      data.p[i] = j.offset_m;
      data.z[i] = j.axis;
      data.R[i] = Eigen::AngleAxisd(q[i], j.axis).toRotationMatrix();
    } else {
      const Eigen::Matrix3d& parent_R = data.R[parent];
      data.p[i] = data.p[parent] + parent_R * j.offset_m;
      data.z[i] = parent_R * j.axis;  // the axis does not move under its own rotation
      data.R[i] = parent_R * Eigen::AngleAxisd(q[i], j.axis).toRotationMatrix();
    }
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
  // The joints on the body's path to the world move it; J_k = z_k x (c - p_k).
  for (int k = b.joint; k >= 0; k = model.parent(k)) data.jacobian.col(k) = data.z[k].cross(c - data.p[k]);
}

const Eigen::VectorXd& gravity_torque(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q) noexcept {
  forward_kinematics(model, data, q);
  std::fill(data.subtree_mass_kg.begin(), data.subtree_mass_kg.end(), 0.0);
  for (Eigen::Vector3d& s : data.subtree_first_moment_kgm) s.setZero();
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const ArmBody& body = model.bodies[b];
    data.subtree_mass_kg[body.joint] += body.mass_kg;
    data.subtree_first_moment_kgm[body.joint] += body.mass_kg * com_position(model, data, static_cast<int>(b));
  }
  const Eigen::Vector3d up(0.0, 0.0, model.gravity_mps2);
  for (int i = model.dof() - 1; i >= 0; --i) {
    // Holding torque = sum_b J_b^T (m_b g e_z) over the carried bodies = g e_z . (z_i x (s_i - m_i p_i)).
    const Eigen::Vector3d lever = data.subtree_first_moment_kgm[i] - data.subtree_mass_kg[i] * data.p[i];
    data.tau[i] = up.dot(data.z[i].cross(lever));
    const int parent = model.parent(i);
    if (parent >= 0) {
      data.subtree_mass_kg[parent] += data.subtree_mass_kg[i];
      data.subtree_first_moment_kgm[parent] += data.subtree_first_moment_kgm[i];
    }
  }
  return data.tau;
}

const Eigen::VectorXd& inverse_dynamics(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& qd, const Eigen::VectorXd& qdd) noexcept {
  forward_kinematics(model, data, q);
  // Forward pass: kinematics of each joint frame from its parent's. Gravity enters as an upward
  // acceleration of the base, so every body's inertial force already carries its weight.
  const Eigen::Vector3d base_accel(0.0, 0.0, model.gravity_mps2);
  for (int i = 0; i < model.dof(); ++i) {
    const int parent = model.parent(i);
    Eigen::Vector3d w = Eigen::Vector3d::Zero(), dw = Eigen::Vector3d::Zero(), a = base_accel;
    if (parent >= 0) {
      const Eigen::Vector3d r = data.p[i] - data.p[parent];  // parent's origin -> this one
      w = data.omega[parent];
      dw = data.alpha[parent];
      a = data.accel[parent] + dw.cross(r) + w.cross(w.cross(r));
    }
    dw += data.z[i] * qdd[i] + w.cross(data.z[i] * qd[i]);
    w += data.z[i] * qd[i];
    data.omega[i] = w;
    data.alpha[i] = dw;
    data.accel[i] = a;
  }
  for (int i = 0; i < model.dof(); ++i) {
    data.joint_force[i].setZero();
    data.joint_moment[i].setZero();
  }
  // Each body's net force and moment about its COM (Newton and Euler, world frame), added to its
  // joint as a force and a moment about the joint's origin.
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const ArmBody& body = model.bodies[b];
    const int j = body.joint;
    const Eigen::Vector3d rc = data.R[j] * body.com_m;
    const Eigen::Vector3d ac = data.accel[j] + data.alpha[j].cross(rc) + data.omega[j].cross(data.omega[j].cross(rc));
    const Eigen::Matrix3d I = data.R[j] * body.inertia_kgm2 * data.R[j].transpose();
    data.force[b] = body.mass_kg * ac;
    data.moment[b] = I * data.alpha[j] + data.omega[j].cross(I * data.omega[j]);
    data.joint_force[j] += data.force[b];
    data.joint_moment[j] += data.moment[b] + rc.cross(data.force[b]);
  }
  // Backward pass: each joint carries its subtree; its torque is the moment about its axis, and its
  // parent carries the same force and moment, moved to the parent's origin.
  for (int i = model.dof() - 1; i >= 0; --i) {
    data.tau[i] = data.z[i].dot(data.joint_moment[i]);
    const int parent = model.parent(i);
    if (parent >= 0) {
      data.joint_force[parent] += data.joint_force[i];
      data.joint_moment[parent] += data.joint_moment[i] + (data.p[i] - data.p[parent]).cross(data.joint_force[i]);
    }
  }
  return data.tau;
}

}  // namespace peha::models
