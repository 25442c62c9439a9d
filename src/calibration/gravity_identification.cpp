#include "peha/calibration/gravity_identification.hpp"

#include "peha/config/atomic_file.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace peha::calibration {
namespace {

constexpr double kLargestFigure = 1e6;

std::string joined(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : ",") + s;
  return out;
}

std::string list(const Eigen::VectorXd& v, double scale, const char* format) {
  std::string out = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) out += (i ? ", " : "") + fmt::format(fmt::runtime(format), v[i] * scale);
  return out + "]";
}

}  // namespace

GravityIdentification identify_gravity(const models::ArmModel& nominal, const std::vector<GravitySample>& samples,
                                       const GravityIdentificationOptions& options) {
  const int dof = nominal.dof();
  const int p = models::gravity_parameter_count(nominal);
  const auto nj = static_cast<Eigen::Index>(options.joints.size());
  if (samples.empty() || nj == 0) throw std::invalid_argument("gravity identification: no samples or no measured joint");
  for (int j : options.joints) {
    if (j < 0 || j >= dof) throw std::invalid_argument(fmt::format("gravity identification: joint {} is not a joint of the arm", j));
  }
  const auto n = static_cast<Eigen::Index>(samples.size()) * nj;
  Eigen::MatrixXd A(n, p);
  Eigen::VectorXd tau(n), weight = Eigen::VectorXd::Ones(n);
  models::ArmData data(nominal);
  Eigen::MatrixXd Y(dof, p);
  for (std::size_t s = 0; s < samples.size(); ++s) {
    const GravitySample& g = samples[s];
    if (g.q_rad.size() != dof || g.tau_Nm.size() != nj || !g.q_rad.allFinite() || !g.tau_Nm.allFinite()) {
      throw std::invalid_argument(fmt::format("gravity identification: sample '{}' has {} angles and {} torques (expected {} and {}, finite)",
                                              g.name, g.q_rad.size(), g.tau_Nm.size(), dof, nj));
    }
    models::gravity_regressor(nominal, data, g.q_rad, Y);
    for (Eigen::Index r = 0; r < nj; ++r) {
      A.row(static_cast<Eigen::Index>(s) * nj + r) = Y.row(options.joints[static_cast<std::size_t>(r)]);
      tau[static_cast<Eigen::Index>(s) * nj + r] = g.tau_Nm[r];
      if (g.uncertainty_Nm.size() == nj) weight[static_cast<Eigen::Index>(s) * nj + r] = 1.0 / std::max(g.uncertainty_Nm[r], 1e-3);
    }
  }

  GravityIdentification fit;
  fit.joints = options.joints;
  fit.prior = models::gravity_parameters(nominal);
  fit.rows = static_cast<int>(n);
  for (int k = 0; k < p; ++k) fit.names.push_back(models::gravity_parameter_name(nominal, k));
  // Columns scaled to unit norm, so that "least change" weighs a kilogram and a kilogram-metre by
  // what they do to the torques; columns the data never see stay at the prior.
  // Weighted least squares: each row divided by its uncertainty (a precise row counts more).
  weight /= weight.mean();
  const Eigen::MatrixXd Aw = weight.asDiagonal() * A;
  Eigen::VectorXd scale(p);
  for (int k = 0; k < p; ++k) scale[k] = Aw.col(k).norm();
  const double largest = scale.maxCoeff();
  Eigen::MatrixXd As = Aw;
  Eigen::VectorXd fitted = Eigen::VectorXd::Ones(p);  // 1: the column is fitted, 0: it keeps the prior
  for (int k = 0; k < p; ++k) {
    // Only frames that carry a body in the prior are fitted: several frames may share an origin (the
    // wrist's three joints), and spreading one body's mass over them would change nothing the
    // torques see but put bodies where the arm has none.
    const bool carries_body = fit.prior[k - k % models::kGravityParametersPerFrame] > 0.0;
    if (!carries_body || scale[k] <= 1e-12 * largest) {
      As.col(k).setZero();
      scale[k] = 1.0;
      fitted[k] = 0.0;
    } else {
      As.col(k) /= scale[k];
    }
  }
  const Eigen::VectorXd b = tau - A * fit.prior;
  const Eigen::VectorXd bw = weight.cwiseProduct(b);
  // Truncated SVD: the least-norm change along the directions whose singular value is at least
  // rank_tolerance x the largest; the others keep the prior.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(As, Eigen::ComputeThinU | Eigen::ComputeThinV);
  fit.singular_values = svd.singularValues();
  const double cutoff = options.rank_tolerance * fit.singular_values[0];
  while (fit.rank < fit.singular_values.size() && fit.singular_values[fit.rank] >= cutoff && fit.singular_values[fit.rank] > 0) ++fit.rank;
  const Eigen::MatrixXd Vr = svd.matrixV().leftCols(fit.rank);
  const Eigen::VectorXd inv_s = fit.singular_values.head(fit.rank).cwiseInverse();
  const Eigen::VectorXd delta = (Vr * (inv_s.asDiagonal() * (svd.matrixU().leftCols(fit.rank).transpose() * bw))).cwiseQuotient(scale).cwiseProduct(fitted);
  fit.theta = fit.prior + delta;
  const Eigen::VectorXd residual = tau - A * fit.theta;
  fit.residual_rms_Nm = std::sqrt(residual.squaredNorm() / static_cast<double>(n));
  fit.residual_max_Nm = residual.cwiseAbs().maxCoeff();
  fit.prior_rms_Nm = std::sqrt(b.squaredNorm() / static_cast<double>(n));
  // Covariance of the estimate: sigma^2 (As^T As)^+ in scaled units (sigma^2 with n - rank degrees of freedom).
  const double dof_left = std::max<double>(1.0, static_cast<double>(n - fit.rank));
  const double sigma2 = weight.cwiseProduct(residual).squaredNorm() / dof_left;
  const Eigen::MatrixXd cov = Vr * inv_s.cwiseAbs2().asDiagonal() * Vr.transpose() * sigma2;
  fit.std = cov.diagonal().cwiseMax(0.0).cwiseSqrt().cwiseQuotient(scale).cwiseProduct(fitted);

  fit.predicted_Nm.resize(static_cast<Eigen::Index>(samples.size()), nj);
  fit.prior_Nm.resize(static_cast<Eigen::Index>(samples.size()), nj);
  const Eigen::VectorXd predicted = A * fit.theta, prior = A * fit.prior;
  std::string worst;
  for (Eigen::Index r = 0; r < n; ++r) {
    fit.predicted_Nm(r / nj, r % nj) = predicted[r];
    fit.prior_Nm(r / nj, r % nj) = prior[r];
    if (std::abs(prior[r]) < options.min_torque_Nm) continue;
    const double change = std::abs(predicted[r] - prior[r]) / std::abs(prior[r]);
    if (change > fit.max_change_fraction) {
      fit.max_change_fraction = change;
      worst = fmt::format("{} at '{}': {:.2f} Nm identified vs {:.2f} Nm nominal (measured {:.2f} Nm)",
                          nominal.joints[static_cast<std::size_t>(options.joints[static_cast<std::size_t>(r % nj)])].name,
                          samples[static_cast<std::size_t>(r / nj)].name, predicted[r], prior[r], tau[r]);
    }
  }
  double uncertainty2 = 0;
  for (const GravitySample& g : samples) uncertainty2 += g.uncertainty_Nm.squaredNorm();
  fit.uncertainty_rms_Nm = std::sqrt(uncertainty2 / static_cast<double>(n));
  const double allowed_Nm = std::max(options.max_residual_rms_Nm, options.max_residual_uncertainty_fraction * fit.uncertainty_rms_Nm);
  if (!(fit.residual_rms_Nm <= allowed_Nm)) {
    throw GravityIdentificationRejected(fmt::format("gravity identification refused: residual RMS {:.3f} Nm > {:.3f} Nm (largest {:.3f} Nm; "
                                                    "the measurements' uncertainty RMS {:.3f} Nm): the torques are not those of a rigid "
                                                    "arm under gravity",
                                                    fit.residual_rms_Nm, allowed_Nm, fit.residual_max_Nm, fit.uncertainty_rms_Nm));
  }
  if (fit.max_change_fraction > options.max_change_fraction) {
    throw GravityIdentificationRejected(fmt::format("gravity identification refused: the identified gravity torque differs from the nominal "
                                                    "model's by {:.0f} % > {:.0f} % ({}): a wrong lever, sign or channel?",
                                                    100 * fit.max_change_fraction, 100 * options.max_change_fraction, worst));
  }
  try {
    (void)models::with_gravity_parameters(nominal, fit.theta);
  } catch (const std::invalid_argument& e) {
    throw GravityIdentificationRejected(std::string("gravity identification refused: ") + e.what());
  }
  return fit;
}

void write_gravity_identification(const std::filesystem::path& path, const models::ArmModel& nominal,
                                  const std::vector<GravitySample>& samples, const GravityIdentification& fit,
                                  const std::string& provenance) {
  std::vector<std::string> joints;
  for (const models::ArmJoint& j : nominal.joints) joints.push_back(j.name);
  config::write_file_atomically(path, [&](std::ostream& out) {
    out << "# The arm's gravity parameters identified on the rig (peha identify-gravity; docs/identification.md).\n"
           "# Per joint frame: mass_kg and first moment h = sum m c (kg m, in the joint's frame). The controller\n"
           "# uses them with `peha run --gravity-identification FILE` or controller.gravity_identification.\n";
    out << "kind: gravity_identification\n";
    std::string quoted = provenance;
    std::replace(quoted.begin(), quoted.end(), '"', '\'');
    out << fmt::format("provenance: \"{}\"\n", quoted);
    out << fmt::format("arm_joints: {}\n", joined(joints));
    std::vector<std::string> measured;
    for (const int j : fit.joints) measured.push_back(joints[static_cast<std::size_t>(j)]);
    out << fmt::format("measured_joints: {}   # the joints whose torques each sample's *_Nm lists give, in order\n", joined(measured));
    out << fmt::format("fit: {{rank: {}, rows: {}, residual_rms_Nm: {:.6g}, residual_max_Nm: {:.6g}, uncertainty_rms_Nm: {:.6g}, "
                       "nominal_rms_Nm: {:.6g}, max_change_fraction: {:.6g}}}\n",
                       fit.rank, fit.rows, fit.residual_rms_Nm, fit.residual_max_Nm, fit.uncertainty_rms_Nm, fit.prior_rms_Nm,
                       fit.max_change_fraction);
    out << "parameters:\n";
    for (std::size_t k = 0; k < fit.names.size(); ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      out << fmt::format("  - {{name: {}, value: {:.10g}, std: {:.4g}, nominal: {:.10g}}}\n", fit.names[k], fit.theta[i], fit.std[i],
                         fit.prior[i]);
    }
    out << "samples:   # measured: the rig's torque at rest (mean of both approaches); identified, nominal: Y(q) theta\n";
    for (std::size_t s = 0; s < samples.size(); ++s) {
      const auto i = static_cast<Eigen::Index>(s);
      out << fmt::format("  - {{name: \"{}\", q_deg: {}, measured_Nm: {}, identified_Nm: {}, nominal_Nm: {}}}\n", samples[s].name,
                         list(samples[s].q_rad, models::kDegPerRad, "{:.4f}"), list(samples[s].tau_Nm, 1, "{:.5f}"),
                         list(fit.predicted_Nm.row(i).transpose(), 1, "{:.5f}"), list(fit.prior_Nm.row(i).transpose(), 1, "{:.5f}"));
    }
  });
}

models::ArmModel read_gravity_identification(const config::Document& doc, const models::ArmModel& nominal) {
  config::Map root = doc.root();
  if (root.string("kind") != "gravity_identification") root.fail("kind", "expected 'gravity_identification'");
  (void)root.string("provenance");
  std::vector<std::string> joints;
  for (const models::ArmJoint& j : nominal.joints) joints.push_back(j.name);
  const std::string arm_joints = root.string("arm_joints");
  if (arm_joints != joined(joints)) root.fail("arm_joints", fmt::format("expected {} (this arm's joints), found {}", joined(joints), arm_joints));
  // The measured joints: each one of this arm's, once; every sample lists one torque per measured joint.
  const std::string measured_text = root.string("measured_joints");
  std::vector<std::string> measured;
  for (std::size_t from = 0; from <= measured_text.size();) {
    const std::size_t comma = std::min(measured_text.find(',', from), measured_text.size());
    measured.push_back(measured_text.substr(from, comma - from));
    from = comma + 1;
  }
  for (std::size_t k = 0; k < measured.size(); ++k) {
    if (std::find(joints.begin(), joints.end(), measured[k]) == joints.end() || std::find(measured.begin(), measured.begin() + static_cast<std::ptrdiff_t>(k), measured[k]) != measured.begin() + static_cast<std::ptrdiff_t>(k)) {
      root.fail("measured_joints", fmt::format("expected distinct joints of this arm ({}), found '{}'", joined(joints), measured[k]));
    }
  }
  config::Map f = root.map("fit");
  (void)f.integer("rank", 0, 10000);
  (void)f.integer("rows", 0, 1000000);
  for (const char* k : {"residual_rms_Nm", "residual_max_Nm", "uncertainty_rms_Nm", "nominal_rms_Nm", "max_change_fraction"}) (void)f.number(k, {0.0, kLargestFigure});
  f.finish();
  const int p = models::gravity_parameter_count(nominal);
  Eigen::VectorXd theta = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::quiet_NaN());
  std::vector<config::Map> params = root.maps("parameters", static_cast<std::size_t>(p), static_cast<std::size_t>(p));
  for (config::Map& m : params) {
    const std::string name = m.string("name");
    int k = 0;
    while (k < p && models::gravity_parameter_name(nominal, k) != name) ++k;
    if (k == p) m.fail("name", fmt::format("'{}' is not a gravity parameter of this arm", name));
    if (!std::isnan(theta[k])) m.fail("name", fmt::format("'{}' appears twice", name));
    theta[k] = m.number("value", {-kLargestFigure, kLargestFigure});
    (void)m.number("std", {0.0, kLargestFigure});
    (void)m.number("nominal", {-kLargestFigure, kLargestFigure});
    m.finish();
  }
  for (config::Map& s : root.maps("samples", 0, 100000)) {
    (void)s.string("name");
    (void)s.numbers("q_deg", {-360.0, 360.0}, 1, 64);
    for (const char* k : {"measured_Nm", "identified_Nm", "nominal_Nm"}) (void)s.numbers(k, {-kLargestFigure, kLargestFigure}, measured.size(), measured.size());
    s.finish();
  }
  root.finish();
  try {
    return models::with_gravity_parameters(nominal, theta);
  } catch (const std::invalid_argument& e) {
    throw config::Error(fmt::format("{}: parameters: {}", doc.name(), e.what()));
  }
}

}  // namespace peha::calibration
