#include "peha/calibration/calibration_file.hpp"

#include "peha/calibration/dataset.hpp"
#include "peha/config/atomic_file.hpp"
#include "peha/config/reader.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace peha::calibration {
namespace {

constexpr double kBig = 1e12;  // numbers in a calibration file are finite; this bounds the range check

void emit_vector(YAML::Emitter& out, const Eigen::VectorXd& v) {
  out << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index i = 0; i < v.size(); ++i) out << v[i];
  out << YAML::EndSeq;
}

void emit_matrix(YAML::Emitter& out, const Eigen::MatrixXd& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < m.rows(); ++r) emit_vector(out, m.row(r).transpose());
  out << YAML::EndSeq;
}

void emit_span(YAML::Emitter& out, const char* key, const Span& s) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq << s.min << s.max << YAML::EndSeq;
}

Eigen::VectorXd to_vector(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

Eigen::MatrixXd to_matrix(const std::vector<std::vector<double>>& rows, std::size_t cols) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(cols));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (std::size_t c = 0; c < cols; ++c) m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = rows[r][c];
  }
  return m;
}

Span read_span(config::Map& map, const char* key) {
  const std::vector<double> v = map.numbers(key, {-kBig, kBig}, 2, 2);
  if (v[0] > v[1]) map.fail(key, fmt::format("expected [min, max], found [{}, {}]", v[0], v[1]));
  return {v[0], v[1]};
}

}  // namespace

void write_calibration(const std::filesystem::path& path, const MuscleCalibration& c) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "muscle" << YAML::Value << c.muscle;
  out << YAML::Key << "data" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "file" << YAML::Value << c.data_file;
  out << YAML::Key << "sha256" << YAML::Value << c.data_sha256;
  out << YAML::Key << "loadcell_zero_N" << YAML::Value << c.loadcell_zero_N;
  out << YAML::EndMap;
  out << YAML::Key << "tendon_spring" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "a_N_per_MPa" << YAML::Value << c.params.a_N_per_Pa * 1e6;
  out << YAML::Key << "b_N_per_MPa" << YAML::Value << c.params.b_N_per_Pa * 1e6;
  out << YAML::Key << "c_N_per_MPa" << YAML::Value << c.params.c_N_per_Pa * 1e6;
  out << YAML::Key << "k_N" << YAML::Value << c.params.k_N;
  out << YAML::Key << "eps0" << YAML::Value << c.params.eps0;
  out << YAML::EndMap;
  out << YAML::Key << "input_ranges" << YAML::Value << YAML::BeginMap;
  emit_span(out, "contraction", c.contraction);
  emit_span(out, "force_N", c.force_N);
  emit_span(out, "pressure_Pa", c.pressure_Pa);
  emit_span(out, "residual_Pa", c.residual_Pa);
  out << YAML::EndMap;
  const CalibrationStats& s = c.stats;
  out << YAML::Key << "fit" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rows_train" << YAML::Value << s.rows_train;
  out << YAML::Key << "rows_heldout" << YAML::Value << s.rows_heldout;
  out << YAML::Key << "restarts" << YAML::Value << s.restarts;
  out << YAML::Key << "restarts_converged" << YAML::Value << s.restarts_converged;
  out << YAML::Key << "lm_seconds" << YAML::Value << s.lm_seconds;
  out << YAML::Key << "spgp_seconds" << YAML::Value << s.spgp_seconds;
  out << YAML::Key << "train_rms_parametric_Pa" << YAML::Value << s.train_rms_parametric_Pa;
  out << YAML::Key << "train_rms_spgp_Pa" << YAML::Value << s.train_rms_spgp_Pa;
  out << YAML::Key << "heldout_rms_parametric_Pa" << YAML::Value << s.heldout_rms_parametric_Pa;
  out << YAML::Key << "heldout_rms_spgp_Pa" << YAML::Value << s.heldout_rms_spgp_Pa;
  out << YAML::EndMap;
  if (c.spgp) {
    const Spgp& g = *c.spgp;
    out << YAML::Key << "spgp" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "input_mean" << YAML::Value;
    emit_vector(out, g.input_mean());
    out << YAML::Key << "input_scale" << YAML::Value;
    emit_vector(out, g.input_scale());
    out << YAML::Key << "output_mean" << YAML::Value << g.output_mean();
    out << YAML::Key << "output_scale" << YAML::Value << g.output_scale();
    out << YAML::Key << "log_b" << YAML::Value;
    emit_vector(out, g.hyper().log_b);
    out << YAML::Key << "log_c" << YAML::Value << g.hyper().log_c;
    out << YAML::Key << "log_sigma2" << YAML::Value << g.hyper().log_sigma2;
    out << YAML::Key << "jitter" << YAML::Value << g.jitter();
    out << YAML::Key << "pseudo_inputs" << YAML::Value;
    emit_matrix(out, g.pseudo_inputs());
    out << YAML::Key << "alpha" << YAML::Value;
    emit_vector(out, g.alpha());
    out << YAML::Key << "variance_matrix" << YAML::Value;
    emit_matrix(out, g.variance_matrix());
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  if (!out.good()) throw std::runtime_error(fmt::format("{}: cannot emit YAML: {}", path.string(), out.GetLastError()));
  config::write_file_atomically(path, [&](std::ostream& file) {
    file << "# peha muscle calibration: Tendon-spring parameters + SPGP residual.\n"
            "# Written by `peha calibrate`. SPGP: inputs (contraction, force_N), output pressure in Pa.\n"
         << out.c_str() << '\n';
  });
}

MuscleCalibration read_calibration(const std::filesystem::path& path) {
  const config::Document doc = config::Document::load_file(path);
  config::Map root = doc.root();
  MuscleCalibration c;
  c.muscle = root.string("muscle");
  config::Map data = root.map("data");
  c.data_file = data.string("file");
  c.data_sha256 = data.string("sha256");
  // Files written before the recording tared its load cell have none: their forces are raw readings.
  c.loadcell_zero_N = data.number_or("loadcell_zero_N", 0.0, {-1000.0, 1000.0});
  data.finish();
  config::Map ts = root.map("tendon_spring");
  c.params.a_N_per_Pa = ts.number("a_N_per_MPa", {-1e7, 1e7}) * 1e-6;
  c.params.b_N_per_Pa = ts.number("b_N_per_MPa", {-1e7, 1e7}) * 1e-6;
  c.params.c_N_per_Pa = ts.number("c_N_per_MPa", {-1e7, 1e7}) * 1e-6;
  c.params.k_N = ts.number("k_N", {1.0, 1e12});
  c.params.eps0 = ts.number("eps0", {-1.0, 1.0});
  ts.finish();
  config::Map ranges = root.map("input_ranges");
  c.contraction = read_span(ranges, "contraction");
  c.force_N = read_span(ranges, "force_N");
  c.pressure_Pa = read_span(ranges, "pressure_Pa");
  // Files written before the residual range was kept: the SPGP may correct by up to the largest
  // pressure the data held, either way.
  c.residual_Pa = ranges.has("residual_Pa") ? read_span(ranges, "residual_Pa") : Span{-c.pressure_Pa.max, c.pressure_Pa.max};
  ranges.finish();
  config::Map fit = root.map("fit");
  CalibrationStats& s = c.stats;
  s.rows_train = static_cast<std::size_t>(fit.integer("rows_train", 0, 1L << 40));
  s.rows_heldout = static_cast<std::size_t>(fit.integer("rows_heldout", 0, 1L << 40));
  s.restarts = static_cast<int>(fit.integer("restarts", 0, 1000000));
  s.restarts_converged = static_cast<int>(fit.integer("restarts_converged", 0, 1000000));
  s.lm_seconds = fit.number("lm_seconds", {0, kBig});
  s.spgp_seconds = fit.number("spgp_seconds", {0, kBig});
  s.train_rms_parametric_Pa = fit.number("train_rms_parametric_Pa", {0, kBig});
  s.train_rms_spgp_Pa = fit.number("train_rms_spgp_Pa", {0, kBig});
  s.heldout_rms_parametric_Pa = fit.number("heldout_rms_parametric_Pa", {0, kBig});
  s.heldout_rms_spgp_Pa = fit.number("heldout_rms_spgp_Pa", {0, kBig});
  fit.finish();
  if (root.has("spgp")) {
    // Inputs are (contraction, force_N), the output pressure in Pa: fixed by the format.
    constexpr std::size_t kDim = 2;
    config::Map g = root.map("spgp");
    const Eigen::VectorXd input_mean = to_vector(g.numbers("input_mean", {-kBig, kBig}, kDim, kDim));
    const Eigen::VectorXd input_scale = to_vector(g.numbers("input_scale", {1e-300, kBig}, kDim, kDim));
    const double output_mean = g.number("output_mean", {-kBig, kBig});
    const double output_scale = g.number("output_scale", {1e-300, kBig});
    SpgpHyper hyper;
    hyper.log_b = to_vector(g.numbers("log_b", {-700, 700}, kDim, kDim));
    hyper.log_c = g.number("log_c", {-700, 700});
    hyper.log_sigma2 = g.number("log_sigma2", {-700, 700});
    const double jitter = g.number("jitter", {0, 1});
    const auto pseudo_rows = g.number_rows("pseudo_inputs", {-kBig, kBig}, 1, 100000, kDim);
    const std::size_t m = pseudo_rows.size();
    const Eigen::VectorXd alpha = to_vector(g.numbers("alpha", {-kBig, kBig}, m, m));
    const Eigen::MatrixXd var = to_matrix(g.number_rows("variance_matrix", {-kBig, kBig}, m, m, m), m);
    g.finish();
    try {
      c.spgp = std::make_shared<const Spgp>(Spgp::from_parts(input_mean, input_scale, output_mean, output_scale,
                                                             hyper, to_matrix(pseudo_rows, kDim), jitter, alpha, var));
    } catch (const std::invalid_argument& e) {
      root.fail("spgp", e.what());
    }
  }
  root.finish();
  return c;
}

void check_calibration(const MuscleCalibration& c, const std::filesystem::path& path, bool with_spgp,
                       const models::JointModel& joint, int side, double min_angle_rad, double max_angle_rad,
                       const CalibrationCheckLimits& limits) {
  const models::MuscleModel& nominal = side == 0 ? joint.agonist : joint.antagonist;
  const std::string who = fmt::format("{}: calibration for muscle '{}' of joint {}", path.string(), nominal.name, joint.name);
  const auto reject = [&](const std::string& why) { throw CalibrationRejected(who + " refused: " + why); };
  if (c.muscle != nominal.name) {
    reject(fmt::format("the file is the calibration of '{}' (swapped files?); give each muscle its own file", c.muscle));
  }
  if (!c.data_file.empty()) {
    std::filesystem::path data = c.data_file;
    if (data.is_relative() && !std::filesystem::exists(data)) data = path.parent_path() / data;
    std::error_code ec;
    if (std::filesystem::is_regular_file(data, ec)) {
      const std::string actual = sha256_file(data);
      if (actual != c.data_sha256) {
        reject(fmt::format("its data {} has SHA-256 {}, but the calibration was fitted to data with {}: the data "
                           "changed after calibrating; calibrate again", data.string(), actual, c.data_sha256));
      }
    }
  }
  const models::TendonSpringParams& p = c.params;
  for (double v : {p.a_N_per_Pa, p.b_N_per_Pa, p.c_N_per_Pa, p.k_N, p.eps0}) {
    if (!std::isfinite(v)) reject("a Tendon-spring parameter is not finite");
  }
  if (!(p.k_N > 0.0)) reject(fmt::format("wire stiffness k = {} N must be > 0", p.k_N));

  const models::MuscleModel calibrated = calibrated_muscle(c, with_spgp, nominal);
  const double ceiling_N = models::force_ceiling_N(nominal);
  const int n = std::max(limits.grid, 2);
  const double supported_std_Pa = limits.max_supported_std_of_supply * joint.supply_pressure_Pa;
  int supported = 0;
  for (int i = 0; i < n; ++i) {
    const double angle = min_angle_rad + (max_angle_rad - min_angle_rad) * i / (n - 1);
    const double eps = models::rigid_contraction(nominal, joint.pulley_radius_m, side == 0 ? +1 : -1, angle);
    for (int j = 0; j < n; ++j) {
      const double force_N = ceiling_N * j / (n - 1);
      const double u = eps + p.eps0 + force_N / p.k_N;
      const double g = models::gain_N_per_Pa(p, u);
      const std::string at = fmt::format("at joint angle {:.1f} deg (contraction {:.4f}) and {:.0f} N", models::rad_to_deg(angle), eps, force_N);
      if (!std::isfinite(g) || g <= p.min_gain_N_per_Pa) {
        reject(fmt::format("g(u) = {:.4g} N/Pa <= 0 {}: the model says the muscle cannot pull there, and the "
                           "controller would command full supply", g, at));
      }
      if (calibrated.residual) {
        const double r = calibrated.residual->pressure_Pa(eps, force_N);
        if (!std::isfinite(r)) reject(fmt::format("the SPGP residual is not finite {}", at));
        // Where the controller evaluates it: inputs clamped to the data's box (SpgpResidual).
        const double x[2] = {std::clamp(eps, c.contraction.min, c.contraction.max), std::clamp(force_N, c.force_N.min, c.force_N.max)};
        const double std_Pa = std::sqrt(std::max(0.0, c.spgp->predict_variance(x)));
        if (!std::isfinite(std_Pa)) reject(fmt::format("the SPGP's variance is not finite {}", at));
        if (std_Pa <= supported_std_Pa) {
          ++supported;
          if (std::abs(r) > limits.max_residual_of_supply * joint.supply_pressure_Pa) {
            reject(fmt::format("the SPGP residual is {:.4g} MPa {}, where it has data (std {:.3g} MPa) (limit +-{:.3g} MPa)",
                               r * 1e-6, at, std_Pa * 1e-6, limits.max_residual_of_supply * joint.supply_pressure_Pa * 1e-6));
          }
        }
      }
      const auto cmd = models::muscle_pressure(calibrated, force_N, eps, joint.supply_pressure_Pa);
      const double nominal_N = models::forward_force_N(nominal.pam, cmd.pressure_Pa, eps);
      if (!std::isfinite(cmd.pressure_Pa) || !std::isfinite(nominal_N)) reject("a model output is not finite " + at);
      if (nominal_N > limits.nominal_force_ratio * ceiling_N) {
        reject(fmt::format("for {:.0f} N it commands {:.3f} MPa, at which the configured model of this muscle "
                           "predicts {:.0f} N, more than {:.2f} x its {:.0f} N ceiling ({}): is this the calibration of "
                           "a weaker muscle?", force_N, cmd.pressure_Pa * 1e-6, nominal_N, limits.nominal_force_ratio,
                           ceiling_N, at));
      }
    }
  }
  if (calibrated.residual && supported == 0) {
    reject(fmt::format("the SPGP has data nowhere in the operating range (its std is above {:.3g} MPa at every grid "
                       "point): not this muscle's data", supported_std_Pa * 1e-6));
  }
}

void apply_calibration(const MuscleCalibration& c, const std::filesystem::path& path, bool with_spgp,
                       models::JointModel& joint, int side, double min_angle_rad, double max_angle_rad) {
  check_calibration(c, path, with_spgp, joint, side, min_angle_rad, max_angle_rad);
  models::MuscleModel& m = side == 0 ? joint.agonist : joint.antagonist;
  m = calibrated_muscle(c, with_spgp, m);
}

models::MuscleModel calibrated_muscle(const MuscleCalibration& c, bool with_spgp, models::MuscleModel muscle) {
  muscle.pam = c.params;
  muscle.loadcell_zero_N = c.loadcell_zero_N;
  muscle.residual = with_spgp && c.spgp ? std::make_shared<SpgpResidual>(c.spgp, c.contraction, c.force_N, c.residual_Pa) : nullptr;
  return muscle;
}

}  // namespace peha::calibration
