#include "peha/models/gravity_parameters.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace peha::models {

Eigen::VectorXd gravity_parameters(const ArmModel& model) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(gravity_parameter_count(model));
  for (const ArmBody& b : model.bodies) {
    const int k = kGravityParametersPerFrame * b.joint;
    theta[k] += b.mass_kg;
    theta.segment<3>(k + 1) += b.mass_kg * b.com_m;
  }
  return theta;
}

std::string gravity_parameter_name(const ArmModel& model, int k) {
  static const char* const kNames[kGravityParametersPerFrame] = {"mass_kg", "hx_kgm", "hy_kgm", "hz_kgm"};
  return fmt::format("{}.{}", model.joints.at(static_cast<std::size_t>(k / kGravityParametersPerFrame)).name,
                     kNames[k % kGravityParametersPerFrame]);
}

void gravity_regressor(const ArmModel& model, ArmData& data, const Eigen::VectorXd& q, Eigen::MatrixXd& Y) noexcept {
  forward_kinematics(model, data, q);
  Y.setZero();
  const Eigen::Vector3d up(0.0, 0.0, model.gravity_mps2);  // g e_z
  // Frame j's parameters load every joint i on its path to the world (j itself included).
  for (int j = 0; j < model.dof(); ++j) {
    const int k = kGravityParametersPerFrame * j;
    for (int i = j; i >= 0; i = model.parent(i)) {
      // e_z . (z_i x v) = v . (e_z x z_i): one vector per row pair, dotted with each column's lever.
      const Eigen::Vector3d w = up.cross(data.z[i]);
      Y(i, k) = w.dot(data.p[j] - data.p[i]);
      Y.block<1, 3>(i, k + 1) = w.transpose() * data.R[j];
    }
  }
}

ArmModel with_gravity_parameters(const ArmModel& model, const Eigen::VectorXd& theta) {
  if (theta.size() != gravity_parameter_count(model)) {
    throw std::invalid_argument(fmt::format("gravity parameters: {} values for a {}-joint arm (expected {})", theta.size(), model.dof(),
                                            gravity_parameter_count(model)));
  }
  ArmModel out = model;
  out.bodies.clear();
  for (int j = 0; j < model.dof(); ++j) {
    const int k = kGravityParametersPerFrame * j;
    const double m = theta[k];
    const Eigen::Vector3d h = theta.segment<3>(k + 1);
    if (m == 0.0 && h.isZero()) continue;
    if (!(m > 0.0)) {
      throw std::invalid_argument(fmt::format("gravity parameters: frame {} has mass {:.4g} kg with first moment ({:.4g}, {:.4g}, {:.4g}) "
                                              "kg m: no body has it",
                                              model.joints[static_cast<std::size_t>(j)].name, m, h.x(), h.y(), h.z()));
    }
    ArmBody body;
    body.name = "identified_" + model.joints[static_cast<std::size_t>(j)].name;
    body.joint = j;
    body.mass_kg = m;
    body.com_m = h / m;
    for (const ArmBody& b : model.bodies) {
      if (b.joint != j) continue;
      const Eigen::Vector3d d = b.com_m - body.com_m;
      body.inertia_kgm2 += b.inertia_kgm2 + b.mass_kg * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
    }
    out.bodies.push_back(body);
  }
  return out;
}

}  // namespace peha::models
