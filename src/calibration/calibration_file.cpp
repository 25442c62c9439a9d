#include "peha/calibration/calibration_file.hpp"

#include "peha/calibration/dataset.hpp"
#include "peha/config/atomic_file.hpp"
#include "peha/config/input_file.hpp"
#include "peha/config/reader.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
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

// The scheme of the integrity section; a file with another (or none) is refused.
constexpr const char* kIntegrityScheme = "peha-calibration-sha256-v1";

// The canonical serialisation of one YAML value: one line `path=value` per scalar, map keys in
// sorted order, list items by index, numbers as the shortest text that reads back to the same
// double. So the hash is of the parameters' values, not of their spelling: re-indenting, reordering
// keys or writing 1e3 for 1000 changes nothing; any changed value, key or list length does.
void canonical_lines(const YAML::Node& node, const std::string& path, std::string& out) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      // Keys sorted as strings, values looked up again: a YAML::Node assigned to (as std::sort
      // would) overwrites the node it refers to.
      std::vector<std::string> keys;
      for (const auto& kv : node) keys.push_back(kv.first.as<std::string>());
      std::sort(keys.begin(), keys.end());
      out += path + "={}\n";
      for (const std::string& key : keys) canonical_lines(node[key], path + "." + key, out);
      break;
    }
    case YAML::NodeType::Sequence:
      out += fmt::format("{}=[{}]\n", path, node.size());
      for (std::size_t i = 0; i < node.size(); ++i) canonical_lines(node[i], fmt::format("{}[{}]", path, i), out);
      break;
    case YAML::NodeType::Scalar: {
      double v = 0;
      out += path + "=" + (config::parse_decimal(node.Scalar(), v) ? fmt::format("{}", v) : "'" + node.Scalar() + "'") + "\n";
      break;
    }
    default:
      out += path + "=~\n";
  }
}

// The hash of each top-level section (every key but `integrity`) and the one over them all.
struct Hashes {
  std::map<std::string, std::string> sections;
  std::string overall;
};

Hashes hash_sections(const YAML::Node& root) {
  Hashes h;
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (key == "integrity") continue;
    std::string lines;
    canonical_lines(kv.second, key, lines);
    h.sections[key] = sha256_hex(lines);
  }
  std::string all = std::string(kIntegrityScheme) + "\n";
  for (const auto& [key, hash] : h.sections) all += key + " " + hash + "\n";
  h.overall = sha256_hex(all);
  return h;
}

// Where a calibration's data file is: as written (relative to where `peha calibrate` ran), else
// that path beside the calibration file, else its name beside the calibration file (the pair moved
// together); the first that exists, or the path as written.
std::filesystem::path data_path(const MuscleCalibration& c, const std::filesystem::path& calibration_file) {
  const std::filesystem::path written = c.data_file;
  if (written.is_absolute()) return written;
  for (const std::filesystem::path& p : {written, calibration_file.parent_path() / written, calibration_file.parent_path() / written.filename()}) {
    std::error_code ec;
    if (std::filesystem::exists(p, ec)) return p;
  }
  return written;
}

// Refuses a file whose integrity section is absent, or whose parameters or data differ from what
// `peha calibrate` hashed.
void check_integrity(const YAML::Node& root, const MuscleCalibration& c, const std::filesystem::path& path) {
  const std::string file = path.string();
  const auto refuse = [&](const std::string& why) { throw CalibrationRejected(fmt::format("{}: {}", file, why)); };
  const YAML::Node integrity = root["integrity"];
  if (!integrity) {
    refuse("no integrity: section: the file was written before calibration files carried a hash over their parameters "
           "and data (or not by peha calibrate); re-run `peha calibrate` on its data to make a checked file");
  }
  const std::string scheme = integrity["scheme"] ? integrity["scheme"].as<std::string>() : "";
  if (scheme != kIntegrityScheme) {
    refuse(fmt::format("integrity.scheme is '{}', expected '{}'; re-run `peha calibrate`", scheme, kIntegrityScheme));
  }
  const YAML::Node listed = integrity["sections"];
  if (!listed || !listed.IsMap() || !integrity["sha256"]) refuse("integrity: needs sha256 and sections; re-run `peha calibrate`");
  const Hashes found = hash_sections(root);
  for (const auto& kv : listed) {
    const std::string key = kv.first.as<std::string>();
    if (!found.sections.count(key)) {
      refuse(fmt::format("section '{}:' is missing although the file announces it (integrity.sections): the file is cut "
                         "off or was edited; re-run `peha calibrate` or restore the file", key));
    }
  }
  for (const auto& [key, hash] : found.sections) {
    if (!listed[key]) refuse(fmt::format("section '{}:' was added after calibrating (integrity.sections does not list it)", key));
    if (listed[key].as<std::string>() != hash) {
      refuse(fmt::format("section '{}:' differs from what `peha calibrate` wrote (its hash is {}, the file says {}): a "
                         "parameter was edited or the file damaged; re-run `peha calibrate`", key, hash, listed[key].as<std::string>()));
    }
  }
  if (integrity["sha256"].as<std::string>() != found.overall) {
    refuse(fmt::format("integrity.sha256 is {}, but the sections hash to {}: the integrity section was edited", integrity["sha256"].as<std::string>(),
                       found.overall));
  }
  // The parameters carry data.sha256; the data file's bytes must still hash to it.
  if (c.data_file.empty()) refuse("data.file is empty: a calibration is checked against the data it was fitted to");
  const std::filesystem::path data = data_path(c, path);
  std::error_code ec;
  if (!std::filesystem::exists(data, ec)) {
    refuse(fmt::format("its data file {} is missing (looked for it as written and beside the calibration file): a "
                       "calibration is only used with the data it was fitted to; restore the data or re-run `peha calibrate`",
                       c.data_file));
  }
  const std::string actual = sha256_file(data);
  if (actual != c.data_sha256) {
    refuse(fmt::format("its data {} has SHA-256 {}, but the calibration was fitted to data with {}: the data changed "
                       "after calibrating; calibrate again", data.string(), actual, c.data_sha256));
  }
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
  // Hashed as the reader will see it: the emitted text parsed back.
  const Hashes h = hash_sections(YAML::Load(out.c_str()));
  YAML::Emitter integrity;
  integrity << YAML::BeginMap << YAML::Key << "integrity" << YAML::Value << YAML::BeginMap;
  integrity << YAML::Key << "scheme" << YAML::Value << kIntegrityScheme;
  integrity << YAML::Key << "sha256" << YAML::Value << h.overall;
  integrity << YAML::Key << "sections" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, hash] : h.sections) integrity << YAML::Key << key << YAML::Value << hash;
  integrity << YAML::EndMap << YAML::EndMap << YAML::EndMap;
  config::write_file_atomically(path, [&](std::ostream& file) {
    file << "# peha muscle calibration: Tendon-spring parameters + SPGP residual.\n"
            "# Written by `peha calibrate`. SPGP: inputs (contraction, force_N), output pressure in Pa.\n"
            "# integrity: SHA-256 of each section's values (docs/calibration.md); any edit refuses the file.\n"
         << integrity.c_str() << '\n' << out.c_str() << '\n';
  });
}

MuscleCalibration read_calibration(const std::filesystem::path& path) {
  std::string text;
  try {
    text = config::read_input_file(path, config::InputKind::kConfig);
  } catch (const config::InputFileError& e) {
    throw config::Error(e.what());
  }
  config::Document doc = config::Document::load_string(text, path.string());
  config::Map root = doc.root();
  MuscleCalibration c;
  // Read by check_integrity (from the same text) after the strict read of every other section.
  if (root.has("integrity")) (void)root.map("integrity");
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
  try {
    check_integrity(YAML::Load(text), c, path);
  } catch (const YAML::Exception& e) {
    throw CalibrationRejected(fmt::format("{}: the integrity: section is malformed ({}); re-run `peha calibrate`", path.string(), e.what()));
  }
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
  // The strength at full supply, against the configured muscle's (its geometry: the datasheet's
  // diameter, length and braid), at every angle of the range where the configured muscle pulls at
  // least a tenth of its ceiling (near its full contraction both go to 0 and the ratio means nothing).
  const int n_angles = std::max(limits.grid, 2);
  for (int i = 0; i < n_angles; ++i) {
    const double angle = min_angle_rad + (max_angle_rad - min_angle_rad) * i / (n_angles - 1);
    const double eps = models::rigid_contraction(nominal, joint.pulley_radius_m, side == 0 ? +1 : -1, angle);
    const double configured_N = models::forward_force_N(nominal.pam, joint.supply_pressure_Pa, eps);
    if (!(configured_N >= 0.1 * ceiling_N)) continue;
    const double calibrated_N = models::forward_force_N(p, joint.supply_pressure_Pa, eps);
    const double ratio = calibrated_N / configured_N;
    if (!std::isfinite(ratio) || ratio > limits.max_strength_ratio || ratio < 1.0 / limits.max_strength_ratio) {
      reject(fmt::format("at {:.3f} MPa and joint angle {:.1f} deg (contraction {:.4f}) the calibration's muscle pulls {:.0f} N, "
                         "{:.3g} x the {:.0f} N of the configured muscle (allowed {:.3g} .. {:.3g} x): no muscle of this size; "
                         "a scaled or edited force model", joint.supply_pressure_Pa * 1e-6, models::rad_to_deg(angle), eps, calibrated_N,
                         ratio, configured_N, 1.0 / limits.max_strength_ratio, limits.max_strength_ratio));
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
