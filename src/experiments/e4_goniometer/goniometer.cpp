#include "peha/experiments/e4_goniometer/goniometer.hpp"

#include "peha/calibration/dataset.hpp"
#include "peha/config/csv_sidecar.hpp"
#include "peha/config/input_file.hpp"
#include "peha/control/butterworth.hpp"
#include "peha/sim/plant_faults.hpp"
#include "peha/control/motion_estimator.hpp"
#include "peha/control/tremor_filter.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/experiments/common/log_row.hpp"
#include "peha/models/joint.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>

namespace peha::experiments {
namespace {

double quantize(double x, double step) { return step > 0.0 ? std::round(x / step) * step : x; }

/// Linear interpolation of `samples` (spaced 1/rate) at time t (s), held at both ends.
double sample_at(const std::vector<double>& samples, double rate_Hz, double t_s) {
  const double x = t_s * rate_Hz;
  if (x <= 0.0) return samples.front();
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= samples.size()) return samples.back();
  const double w = x - static_cast<double>(i);
  return samples[i] * (1.0 - w) + samples[i + 1] * w;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    const auto b = cell.find_first_not_of(" \t\r");
    const auto e = cell.find_last_not_of(" \t\r");
    cells.push_back(b == std::string::npos ? std::string() : cell.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

}  // namespace

GoniometerTrace synthesize_goniometer(const ArmScenario::Goniometer& g, const ArmScenario::Goniometer::Movement& m,
                                      std::uint64_t seed) {
  GoniometerTrace trace;
  trace.name = m.name;
  trace.sample_rate_Hz = g.sample_rate_Hz;
  const double cycle_s = 2.0 * (m.pause_s + m.move_s);
  const double duration_s = m.repetitions * cycle_s + m.pause_s;
  const auto n = static_cast<std::size_t>(std::llround(duration_s * g.sample_rate_Hz)) + 1;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / g.sample_rate_Hz;
    // Within a cycle: pause at `from`, move to `to`, pause, move back.
    const double tc = std::fmod(t, cycle_s);
    double angle = m.from_rad;
    if (t < m.repetitions * cycle_s) {
      if (tc < m.pause_s) {
        angle = m.from_rad;
      } else if (tc < m.pause_s + m.move_s) {
        angle = m.from_rad + (m.to_rad - m.from_rad) * sim::minimum_jerk((tc - m.pause_s) / m.move_s);
      } else if (tc < 2.0 * m.pause_s + m.move_s) {
        angle = m.to_rad;
      } else {
        angle = m.to_rad + (m.from_rad - m.to_rad) * sim::minimum_jerk((tc - 2.0 * m.pause_s - m.move_s) / m.move_s);
      }
    }
    trace.voluntary_rad.push_back(angle);
    // The tremor starts from 0 at t = 0, so the arm starts where the person does.
    angle += m.tremor_amplitude_rad * std::sin(2.0 * std::numbers::pi * m.tremor_frequency_Hz * t);
    trace.truth_rad.push_back(angle);
    trace.measured_rad.push_back(quantize(angle + g.noise_rad * noise(rng), g.resolution_rad));
  }
  return trace;
}

std::uint64_t goniometer_noise_seed(std::uint64_t seed, std::size_t k) noexcept {
  return seed + 0x9E3779B97F4A7C15ull * k;  // the golden-ratio stride: distinct seeds, the first unchanged
}

std::vector<GoniometerTrace> synthesize_goniometers(const ArmScenario::Goniometer& g, const ArmScenario::Goniometer::Movement& m,
                                                    std::uint64_t seed) {
  std::vector<GoniometerTrace> traces;
  for (std::size_t k = 0; k < g.joints.size(); ++k) traces.push_back(synthesize_goniometer(g, m, goniometer_noise_seed(seed, k)));
  return traces;
}

GoniometerTrace read_goniometer_csv(const std::filesystem::path& path, double sample_rate_Hz, double min_rad,
                                    double max_rad) {
  std::istringstream in;
  try {
    in.str(config::read_input_file(path, config::InputKind::kCsv));
  } catch (const config::InputFileError& e) {
    throw calibration::DataError(fmt::format("the goniometer recording {}", e.what()));
  }
  const std::string file = path.string();
  std::string line;
  int line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    header = split_csv(line);
    break;
  }
  if (header.empty()) throw calibration::DataError(fmt::format("{}: no header row (expected t_s and elbow_angle_deg or elbow_angle_rad)", file));
  int col_t = -1, col_angle = -1;
  double scale = 1.0;
  for (std::size_t c = 0; c < header.size(); ++c) {
    const std::string& h = header[c];
    const int col = static_cast<int>(c);
    auto take = [&](int& slot) {
      if (slot >= 0) throw calibration::DataError(fmt::format("{}:{}:{}: column '{}' appears twice", file, line_no, c + 1, h));
      slot = col;
    };
    if (h == "t_s") {
      take(col_t);
    } else if (h == "elbow_angle_deg") {
      take(col_angle);
      scale = models::kRadPerDeg;
    } else if (h == "elbow_angle_rad") {
      take(col_angle);
      scale = 1.0;
    } else if (h == "elbow_angle" || h == "angle" || h == "t") {
      throw calibration::DataError(fmt::format("{}:{}:{}: column '{}' has no unit: name it t_s, elbow_angle_deg or elbow_angle_rad",
                                           file, line_no, c + 1, h));
    }
  }
  if (col_t < 0) throw calibration::DataError(fmt::format("{}:{}: missing column t_s", file, line_no));
  if (col_angle < 0) throw calibration::DataError(fmt::format("{}:{}: missing column elbow_angle_deg or elbow_angle_rad", file, line_no));

  GoniometerTrace trace;
  trace.name = path.stem().string();
  trace.sample_rate_Hz = sample_rate_Hz;
  std::vector<double> times;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split_csv(line);
    if (cells.size() != header.size()) {
      throw calibration::DataError(fmt::format("{}:{}: expected {} cells, found {}", file, line_no, header.size(), cells.size()));
    }
    double v[2];
    const int cols[2] = {col_t, col_angle};
    for (int i = 0; i < 2; ++i) {
      const std::string& cell = cells[static_cast<std::size_t>(cols[i])];
      const auto [ptr, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), v[i]);
      if (ec != std::errc() || ptr != cell.data() + cell.size() || !std::isfinite(v[i])) {
        throw calibration::DataError(fmt::format("{}:{}:{}: {}: expected a finite number, found '{}'", file, line_no, cols[i] + 1,
                                             header[static_cast<std::size_t>(cols[i])], cell));
      }
    }
    const double angle = v[1] * scale;
    if (angle < min_rad - 1e-12 || angle > max_rad + 1e-12) {
      throw calibration::DataError(fmt::format("{}:{}:{}: {} = {} is outside the exoskeleton's elbow range [{:.1f}, {:.1f}] deg", file,
                                           line_no, col_angle + 1, header[static_cast<std::size_t>(col_angle)], v[1],
                                           models::rad_to_deg(min_rad), models::rad_to_deg(max_rad)));
    }
    if (!times.empty()) {
      const double dt = v[0] - times.back();
      if (std::abs(dt * sample_rate_Hz - 1.0) > 0.02) {
        throw calibration::DataError(fmt::format("{}:{}:{}: t_s steps by {} s; the goniometer is configured for {} Hz ({} s, within 2 %)",
                                             file, line_no, col_t + 1, dt, sample_rate_Hz, 1.0 / sample_rate_Hz));
      }
    }
    times.push_back(v[0]);
    trace.measured_rad.push_back(angle);
  }
  if (trace.measured_rad.size() < 2) throw calibration::DataError(fmt::format("{}: fewer than 2 samples", file));
  trace.truth_rad = trace.measured_rad;  // a recording is all we know of the person
  trace.voluntary_rad = trace.measured_rad;
  return trace;
}

void write_goniometer_csv(const std::filesystem::path& path, const GoniometerTrace& trace) {
  config::remove_csv_sidecar(path);
  std::ofstream out(path);
  out << "t_s,elbow_angle_deg\n";
  for (std::size_t k = 0; k < trace.measured_rad.size(); ++k) {
    out << fmt::format("{:.4f},{:.4f}\n", static_cast<double>(k) / trace.sample_rate_Hz, models::rad_to_deg(trace.measured_rad[k]));
  }
  out.close();
  if (!out) throw calibration::DataError(fmt::format("{}: write failed", path.string()));
  config::write_csv_sidecar(path, {{"t_s", "elbow_angle_deg"},
                                   trace.measured_rad.size(),
                                   {fmt::format("goniometer recording '{}', {} Hz; read by peha run --experiment goniometer --goniometer-csv",
                                                trace.name, trace.sample_rate_Hz)},
                                   {{"sample_rate_Hz", trace.sample_rate_Hz}}});
}

const char* to_string(GoniometerVariant v) { return v == GoniometerVariant::kOpenLoop ? "open_loop" : "feedback"; }

namespace {

/// The io joints E4 holds (named in goniometer.angles_deg, not driven), in io order.
std::vector<std::size_t> held_joints(const ArmScenario& scenario) {
  std::vector<std::size_t> held;
  for (std::size_t i = 0; i < scenario.goniometer.held_rad.size(); ++i) {
    if (!std::isnan(scenario.goniometer.held_rad[i])) held.push_back(i);
  }
  return held;
}

/// "R" of "R_EFE": the side an io joint is on.
std::string_view side_of(const std::string& io_joint) { return std::string_view(io_joint).substr(0, io_joint.find('_')); }

}  // namespace

std::string goniometer_log_prefix(const ArmScenario& scenario, std::size_t io_joint) {
  const std::vector<int>& driven = scenario.goniometer.joints;
  // One driven joint keeps the single-elbow names (tools/plot_goniometer.py, the videos read them).
  const bool single = driven.size() == 1 && driven.front() == static_cast<int>(io_joint);
  return single ? std::string() : arm_log_prefix(scenario, io_joint) + "_";
}

namespace {

/// The log's columns before the replay's (goniometer_log_columns without them).
std::vector<std::string> goniometer_own_columns(const ArmScenario& scenario) {
  const ArmScenario::Goniometer& g = scenario.goniometer;
  auto prefix = [&](int joint) { return goniometer_log_prefix(scenario, static_cast<std::size_t>(joint)); };
  std::vector<std::string> columns = {"t_s", "operator_active"};
  for (const int j : g.joints) {
    for (const char* c : {"person_elbow_deg", "goniometer_deg", "filtered_elbow_deg", "filtered_rate_degps", "filtered_accel_degps2",
                          "tau_elbow_cmd_Nm", "plant_elbow_deg", "elbow_encoder_deg"}) {
      columns.push_back(prefix(j) + c);
    }
  }
  for (const std::size_t h : held_joints(scenario)) {
    columns.push_back(fmt::format("plant_{}_deg", arm_log_prefix(scenario, h)));
    columns.push_back(fmt::format("tau_{}_gravity_Nm", arm_log_prefix(scenario, h)));
  }
  for (const int j : g.joints) {
    for (const char* c : {"tau_motor_cmd_Nm", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa", "agonist_loadcell_N",
                          "antagonist_loadcell_N", "plant_agonist_force_N", "plant_antagonist_force_N", "plant_agonist_contraction",
                          "plant_antagonist_contraction", "plant_agonist_pressure_MPa", "plant_antagonist_pressure_MPa"}) {
      columns.push_back(prefix(j) + c);
    }
  }
  columns.push_back("plant_tension_min_N");
  return columns;
}

/// A column of the log's last block: io joint `io`'s hardware::kSensorColumns[field] or, from
/// kSensorColumns.size() on, its kCommandColumns[field - kSensorColumns.size()].
struct ReplayColumn {
  std::size_t io, field;
};

/// Per io joint (goniometer_log_prefix), each replay column the log's own columns lack (a driven
/// joint's load cells and commands are there already): what a replay needs of every joint.
std::vector<ReplayColumn> replay_columns(const ArmScenario& scenario, std::vector<std::string>* names) {
  std::vector<std::string> columns = goniometer_own_columns(scenario);
  std::vector<ReplayColumn> out;
  for (std::size_t io = 0; io < scenario.plant.actuated.size(); ++io) {
    const std::string prefix = goniometer_log_prefix(scenario, io);
    for (std::size_t f = 0; f < hardware::kSensorColumns.size() + hardware::kCommandColumns.size(); ++f) {
      const std::size_t n = hardware::kSensorColumns.size();
      const std::string name = prefix + (f < n ? hardware::kSensorColumns[f] : hardware::kCommandColumns[f - n]);
      if (std::find(columns.begin(), columns.end(), name) != columns.end()) continue;
      columns.push_back(name);
      out.push_back({io, f});
    }
  }
  if (names) *names = std::move(columns);
  return out;
}

}  // namespace

std::vector<std::string> goniometer_log_columns(const ArmScenario& scenario) {
  std::vector<std::string> columns;
  (void)replay_columns(scenario, &columns);
  return columns;
}

hardware::HardwareRequest goniometer_hardware(const ArmScenario& scenario, const sim::ArmPlantParams& plant) {
  hardware::HardwareRequest r = arm_hardware(scenario, plant, true);
  for (std::size_t j = 0; j < r.log_prefixes.size(); ++j) r.log_prefixes[j] = goniometer_log_prefix(scenario, j);
  return r;
}

std::vector<GoniometerSource> logged_goniometers(const ArmScenario& scenario, const std::filesystem::path& log) {
  std::vector<std::string> names = {"t_s"};
  for (const int j : scenario.goniometer.joints) names.push_back(goniometer_log_prefix(scenario, static_cast<std::size_t>(j)) + "goniometer_deg");
  std::vector<std::vector<double>> cols = runtime::read_csv_log_columns(log, names);
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (cols[c].empty()) throw std::runtime_error(fmt::format("replay: {}: no column {} (an E4 log's goniometer reading)", log.string(), names[c]));
  }
  auto t_s = std::make_shared<const std::vector<double>>(std::move(cols[0]));
  std::vector<GoniometerSource> readings;
  for (std::size_t k = 1; k < cols.size(); ++k) {
    auto rad = std::make_shared<std::vector<double>>(std::move(cols[k]));
    for (double& a : *rad) a = models::deg_to_rad(a);
    // The row of time t (the replay gives the log's own t_s), or the last before it; no allocation.
    readings.push_back([t_s, rad](double t) {
      const auto after = std::upper_bound(t_s->begin(), t_s->end(), t);
      return (*rad)[after == t_s->begin() ? 0 : static_cast<std::size_t>(after - t_s->begin()) - 1];
    });
  }
  return readings;
}

double goniometer_run_duration_s(const ArmScenario& scenario, const GoniometerTrace& trace) {
  return scenario.goniometer.settle_s + trace.duration_s() + scenario.goniometer.tail_s;
}

double goniometer_reading(const ArmScenario& scenario, const GoniometerTrace& trace, double t_s) noexcept {
  // Still at the first sample during settle_s, then the trace, then its last sample.
  const ArmScenario::Goniometer& g = scenario.goniometer;
  const double x = (t_s - g.settle_s) * g.sample_rate_Hz;
  if (x <= 0.0) return trace.measured_rad.front();
  const auto i = static_cast<std::size_t>(std::llround(x));
  return i < trace.measured_rad.size() ? trace.measured_rad[i] : trace.measured_rad.back();
}

sim::ArmPlantParams goniometer_plant_params(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces) {
  const ArmScenario::Goniometer& g = scenario.goniometer;
  if (traces.size() != g.joints.size()) {
    throw std::invalid_argument(fmt::format("E4: {} goniometer traces for {} driven joints", traces.size(), g.joints.size()));
  }
  sim::ArmPlantParams p = scenario.plant;
  // Every io joint the posture names at its angle, each driven joint where its person starts; the
  // others (the wrists unless named) where the plant starts them.
  std::vector<double> start = g.held_rad;
  start.resize(scenario.plant.actuated.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < g.joints.size(); ++k) start[static_cast<std::size_t>(g.joints[k])] = traces[k].truth_rad.front();
  for (std::size_t i = 0; i < start.size(); ++i) {
    double& q0 = p.initial_q_rad.at(static_cast<std::size_t>(scenario.controller.joints[i].model_joint));
    if (!std::isnan(start[i])) q0 = start[i];
    start[i] = q0;
  }
  const double release_s = g.settle_s - 1.0;
  // The operator holds the whole arm where it starts while the compensation comes on (the person keeps
  // the hand still: the constant-pressure wrist, vented at power-on, would otherwise swing to where its
  // pressures put it), then lets go.
  p.operator_hands.moves.push_back({"start", 0.0, release_s, release_s, start});
  p.faults = scenario.faults;
  return p;
}

GoniometerResult run_goniometer(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces, GoniometerVariant variant,
                                runtime::RowSink* log) {
  const hardware::Hardware arm =
      hardware::open_backend(hardware::BackendUri{}, goniometer_hardware(scenario, goniometer_plant_params(scenario, traces)));
  return run_goniometer(scenario, traces, variant, arm, log);
}

GoniometerResult run_goniometer(const ArmScenario& scenario, const std::vector<GoniometerTrace>& traces, GoniometerVariant variant,
                                const hardware::Hardware& hw, runtime::RowSink* log) {
  if (traces.size() != scenario.goniometer.joints.size()) {
    throw std::invalid_argument(fmt::format("run_goniometer: {} traces for {} driven joints", traces.size(), scenario.goniometer.joints.size()));
  }
  for (const GoniometerTrace& trace : traces) {
    if (trace.measured_rad.empty() || trace.truth_rad.size() != trace.measured_rad.size() ||
        trace.measured_rad.size() != traces.front().measured_rad.size() ||
        (!trace.voluntary_rad.empty() && trace.voluntary_rad.size() != trace.measured_rad.size())) {
      throw std::invalid_argument("run_goniometer: empty trace, truth/voluntary/measured size mismatch or traces of different lengths");
    }
  }
  const double settle_s = scenario.goniometer.settle_s, rate_Hz = scenario.goniometer.sample_rate_Hz;
  std::vector<GoniometerSource> readings, persons;
  if (hw.replay) {
    readings = logged_goniometers(scenario, hw.replay->log());  // the person is what the goniometers read
  } else {
    for (const GoniometerTrace& trace : traces) {
      readings.push_back([&](double t) { return goniometer_reading(scenario, trace, t); });
      // Judged against what the person means to do: a tremor is not followed (its own figure).
      const std::vector<double>& person = trace.voluntary_rad.empty() ? trace.truth_rad : trace.voluntary_rad;
      persons.push_back([&person, rate_Hz, settle_s](double t) { return sample_at(person, rate_Hz, t - settle_s); });
    }
  }
  return run_goniometer_on(scenario, traces.front().name, variant, goniometer_run_duration_s(scenario, traces.front()), *hw.backend,
                           dynamic_cast<sim::ArmBackend*>(hw.backend.get()), readings, persons, log);
}

namespace {

/// The goniometer's noise as the acceleration estimator sees it: its noise and its quantisation's.
double goniometer_noise_rad(const ArmScenario::Goniometer& g) { return std::hypot(g.noise_rad, g.resolution_rad / std::sqrt(12.0)); }

/// E4's controller: the scenario's, with the PAMs' share of the torque at goniometer.pam_cutoff_Hz
/// (docs/right-arm.md, E4 "The PAMs' share").
control::ArmControllerModel e4_controller(const ArmScenario& scenario) {
  control::ArmControllerModel m = scenario.controller;
  m.allocation.pam_cutoff_Hz = scenario.goniometer.pam_cutoff_Hz;
  return m;
}

/// One driven joint: its goniometer's filter and derivatives, the rate's smoothing, the acceleration's
/// estimator, its command and its trajectories.
struct Driven {
  Driven(std::size_t io, int q, const ArmScenario& s, std::size_t steps)
      : io(io),
        q(q),
        derivative(s.goniometer.filter_order, s.goniometer.cutoff_Hz, s.goniometer.sample_rate_Hz),
        rate_smooth(s.goniometer.smoothing_order, s.goniometer.rate_cutoff_Hz, s.goniometer.sample_rate_Hz),
        acceleration_estimator(control::make_motion_estimator(s.goniometer.sample_rate_Hz, goniometer_noise_rad(s.goniometer),
                                                              s.goniometer.acceleration_jerk_density_rad2ps5)),
        command_smooth(s.goniometer.smoothing_order, s.goniometer.command_cutoff_Hz, 1.0 / s.period_s),
        tremor_model(s.goniometer.tremor ? std::optional(control::make_tremor_filter(*s.goniometer.tremor)) : std::nullopt),
        tremor(tremor_model ? control::make_tremor_filter_data(*tremor_model) : control::TremorFilterData{}),
        exo(steps + 1),
        truth(steps + 1),
        command(steps + 1),
        raw_command(steps + 1) {}
  std::size_t io = 0;
  int q = 0;  ///< model joint
  control::FilteredDerivative derivative;
  control::FilteredDerivative::Derivatives d{};
  control::ButterworthFilter rate_smooth;  ///< at the goniometer's rate
  /// The inverse dynamics' acceleration: quieter than the second difference's for the same angle lag
  const control::MotionEstimatorModel acceleration_estimator;
  control::MotionEstimatorData motion;
  control::ButterworthFilter command_smooth;  ///< at the control rate
  /// The person's tremor out of the reading before everything else (goniometer.tremor; absent: none)
  std::optional<control::TremorFilterModel> tremor_model;
  control::TremorFilterData tremor;
  double rate = 0.0;                      ///< the smoothed rate at the latest sample, rad/s
  double sample_time_s = 0.0;             ///< when the latest goniometer sample came
  bool sampled = false;
  double goniometer = 0.0, tau_cmd = 0.0;
  /// The command without the smoothing (the inverse dynamics of the raw derivatives at the goniometer's
  /// rate, held, plus the same feedback): the reference the smoothing's delay is measured against.
  double tau_id_raw = 0.0, tau_raw = 0.0;
  /// After a recovery, until it has caught the person: the reference, from where the joint was and
  /// moving toward the person at rejoin_rate_radps (rad).
  bool rejoining = false;
  double rejoin_rad = 0.0;
  std::vector<double> exo, truth;  ///< the exoskeleton's and the person's angle per cycle, rad
  std::vector<double> command, raw_command;  ///< tau_cmd and tau_raw per cycle, Nm
  GoniometerJointResult r;
};

/// A driven joint's first block of log columns (goniometer_log_columns, the same names in order).
struct DrivenAngleColumns {
  double person_elbow_deg, goniometer_deg, filtered_elbow_deg, filtered_rate_degps, filtered_accel_degps2, tau_elbow_cmd_Nm,
      plant_elbow_deg, elbow_encoder_deg;
};
/// A held joint's block.
struct HeldColumns {
  double plant_deg, tau_gravity_Nm;
};
/// A driven joint's actuator block.
struct DrivenActuatorColumns {
  double tau_motor_cmd_Nm, agonist_pressure_cmd_MPa, antagonist_pressure_cmd_MPa, agonist_loadcell_N, antagonist_loadcell_N,
      plant_agonist_force_N, plant_antagonist_force_N, plant_agonist_contraction, plant_antagonist_contraction, plant_agonist_pressure_MPa,
      plant_antagonist_pressure_MPa;
};

/// One E4 run: the controller, its per-cycle step (goniometer -> filter -> inverse dynamics ->
/// torque command) and observation (trajectories, envelope, log row), and the buffers the analysis
/// reads. Every buffer is sized here, before the loop: step, hold and observe allocate nothing.
struct GoniometerRun {
  GoniometerRun(const ArmScenario& scenario, GoniometerVariant variant, std::size_t steps, const std::vector<GoniometerSource>& readings,
                const std::vector<GoniometerSource>& persons, const sim::ArmBackend* sim)
      : scenario(scenario),
        g(scenario.goniometer),
        readings(readings),
        persons(persons),
        sim(sim),
        feedback(variant == GoniometerVariant::kFeedback),
        decimation(static_cast<std::size_t>(std::llround(1.0 / (g.sample_rate_Hz * scenario.period_s)))),
        controller(e4_controller(scenario)),
        controller_nan(scenario.faults),
        arm(controller.model().arm),
        arm_data(arm),
        held(held_joints(scenario)),
        held_q(held.size(), std::vector<double>(steps + 1)),
        replay(replay_columns(scenario, nullptr)),
        row(goniometer_log_columns(scenario).size()) {
    for (const int j : g.joints) controller.set_mode(j, control::ArmJointMode::kCommanded);
    joints = arm_joint_models(controller.model());
    const auto dof = static_cast<Eigen::Index>(arm.joints.size());
    q = Eigen::VectorXd::Zero(dof), qd = Eigen::VectorXd::Zero(dof), qdd = Eigen::VectorXd::Zero(dof);
    driven.reserve(g.joints.size());
    for (const int j : g.joints) {
      const auto io = static_cast<std::size_t>(j);
      driven.emplace_back(io, controller.model().joints[io].model_joint, scenario, steps);
      driven.back().r.joint = arm_joint_names(scenario)[io];
    }
    for (const control::ArmActuatedJoint& j : controller.model().joints) joints_q.push_back(j.model_joint);
    // The held joints a torque can drive hold by the same inverse dynamics plus an impedance; a joint
    // at a constant pressure (the wrist) keeps it.
    for (const std::size_t h : held) {
      if (controller.model().joints[h].mode == control::ArmJointMode::kHoldPressure) continue;
      controller.set_mode(static_cast<int>(h), control::ArmJointMode::kCommanded);
      torque_held.push_back(h);
    }
    for (std::size_t i = 0; i < controller.model().joints.size(); ++i) {
      if (controller.model().joints[i].mode == control::ArmJointMode::kHoldPressure) passive.push_back(i);
    }
    passive_peak_speed_radps.assign(passive.size(), 0.0);
    hold_offset_rad.assign(controller.model().joints.size(), 0.0);
    encoder_velocity.assign(controller.model().joints.size(), control::VelocityEstimator{.cutoff_Hz = g.encoder_velocity_cutoff_Hz});
  }

  void step(const io::SensorState& state, io::Command& command, std::size_t k) {
    if (k % decimation == 0) sample_goniometers(state);
    // The reference at the control rate: extrapolated from the latest sample with the smoothed
    // derivatives, and the inverse dynamics of it every cycle (no 200 Hz staircase).
    encoders_into_q(state);
    // By the time between the encoder readings, as the controller's own rate (a board's late cycle).
    const double encoder_dt_s = std::isnan(encoder_time_s) ? 0.0 : state.time_s - encoder_time_s;
    encoder_time_s = state.time_s;
    for (std::size_t i = 0; i < encoder_velocity.size(); ++i) encoder_velocity[i].update(state.joints[i].angle_rad, encoder_dt_s);
    for (Driven& j : driven) {
      const double dt = state.time_s - j.sample_time_s;
      const double acceleration = control::read_motion_estimate(j.acceleration_estimator, j.motion, state.time_s).acceleration_radps2;
      q[j.q] = j.d.value + (j.rate + 0.5 * acceleration * dt) * dt;
      qd[j.q] = j.rate + acceleration * dt;
      qdd[j.q] = acceleration;
    }
    rejoin_step(state);
    const Eigen::VectorXd& tau = models::inverse_dynamics(arm, arm_data, q, qd, qdd);
    for (Driven& j : driven) {
      const double q_exo = state.joints[j.io].angle_rad, qd_exo = encoder_velocity[j.io].velocity_radps;
      double tau_cmd = tau[j.q];
      j.tau_raw = j.tau_id_raw;
      if (feedback) {  // the exo's encoder and E4's own rate of it
        auto impedance = [&](double q_ref, double qd_ref) {
          return g.feedback_stiffness_Nm_per_rad * (q_ref - q_exo) + g.feedback_damping_Nms_per_rad * (qd_ref - qd_exo);
        };
        const double toward_reference = impedance(q[j.q], qd[j.q]);
        tau_cmd += toward_reference;
        // The raw reference is the goniometer's held sample, or the rejoining reference while it runs.
        j.tau_raw += j.rejoining ? toward_reference : impedance(j.d.value, j.d.rate);
      }
      if (k == 0) j.command_smooth.reset(tau_cmd);
      j.tau_cmd = j.command_smooth.step(tau_cmd);
      j.command[k] = j.tau_cmd;
      j.raw_command[k] = j.tau_raw;
      j.r.peak_torque_command_Nm = std::max(j.r.peak_torque_command_Nm, std::abs(j.tau_cmd));
      controller.set_desired_torque(static_cast<int>(j.io), j.tau_cmd);
    }
    for (const std::size_t h : torque_held) {
      const auto m = static_cast<std::size_t>(joints_q[h]);
      controller.set_desired_torque(static_cast<int>(h), tau[static_cast<Eigen::Index>(m)] +
                                                             g.hold_stiffness_Nm_per_rad * (g.held_rad[h] + hold_offset_rad[h] - state.joints[h].angle_rad) -
                                                             g.hold_damping_Nms_per_rad * encoder_velocity[h].velocity_radps);
    }
    controller.update(state, command);
    controller_nan.apply(state.time_s, command);
  }

  /// The operator's recovery from an outage: the next step starts the reference and the held
  /// postures from where the joints are (the controller itself restarts from the measured pressures).
  void rejoin() noexcept { rejoin_pending = true; }

  void hold(std::size_t k) {  // no new sample: the command is held
    for (Driven& j : driven) {
      j.exo[k] = k ? j.exo[k - 1] : 0.0;
      j.truth[k] = k ? j.truth[k - 1] : 0.0;
    }
    for (std::vector<double>& h : held_q) h[k] = k ? h[k - 1] : 0.0;
    for (Driven& j : driven) {
      j.command[k] = k ? j.command[k - 1] : 0.0;
      j.raw_command[k] = k ? j.raw_command[k - 1] : 0.0;
    }
  }

  void observe(std::size_t k, const io::SensorState& state, const io::Command& sent, runtime::RowSink* log) {
    const double t = state.time_s;
    const sim::ArmTruth* tr = sim ? &sim->sampled_truth() : nullptr;
    // Without the simulator: the exoskeleton by its encoders, the person by the goniometer.
    auto angle = [&](std::size_t io) { return tr ? tr->actuated_q_rad[io] : state.joints[io].angle_rad; };
    for (std::size_t n = 0; n < driven.size(); ++n) {
      Driven& j = driven[n];
      j.exo[k] = angle(j.io);
      j.truth[k] = persons.empty() ? j.goniometer : persons[n](t);
    }
    for (std::size_t h = 0; h < held.size(); ++h) held_q[h][k] = angle(held[h]);
    if (t >= g.settle_s - 1.0) {  // after the release: the operator's hands no longer hold the wrist
      for (std::size_t p = 0; p < passive.size(); ++p) {
        const double speed = tr ? tr->qd_radps[static_cast<std::size_t>(joints_q[passive[p]])] : controller.diagnostics()[passive[p]].velocity_radps;
        passive_peak_speed_radps[p] = std::max(passive_peak_speed_radps[p], std::abs(speed));
      }
    }
    double tension_min_N = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < static_cast<std::size_t>(state.joint_count); ++a) {
      safety::JointSample j = arm_joint_sample(state, sent, tr, a);
      if (controller.wires_slack_on_purpose(state.time_s)) j.min_tension_N = std::numeric_limits<double>::infinity();  // start-up tare
      envelope.observe(a, j);
      tension_min_N = std::min(tension_min_N, j.min_tension_N);
      peak_motor_torque_Nm = std::max(peak_motor_torque_Nm, std::abs(j.motor_torque_Nm));
    }
    if (log) {
      write_row(k, state, sent, tr, tension_min_N);
      log->push_row(row);
    }
  }

  const ArmScenario& scenario;
  const ArmScenario::Goniometer& g;
  const std::vector<GoniometerSource>& readings;
  const std::vector<GoniometerSource>& persons;
  const sim::ArmBackend* sim;
  const bool feedback;
  const std::size_t decimation;  ///< control cycles per goniometer sample
  /// After a recovery: each driven joint's reference starts where the joint is and moves toward
  /// the person (q, set just before) at rejoin_rate_radps, at rest otherwise, until it reaches a
  /// person slower than that rate; each held joint's posture starts where it is and closes its gap
  /// at the same rate. Replaces q, qd, qdd of a joint still rejoining.
  void rejoin_step(const io::SensorState& state) noexcept {
    const double dt = std::isnan(rejoin_time_s) ? 0.0 : std::max(0.0, state.time_s - rejoin_time_s);
    rejoin_time_s = state.time_s;
    const double step = g.rejoin_rate_radps * dt;
    if (rejoin_pending) {
      rejoin_pending = false;
      for (Driven& j : driven) j.rejoining = true, j.rejoin_rad = state.joints[j.io].angle_rad;
      rejoin_from_s = state.time_s;
      for (const std::size_t h : torque_held) hold_offset_rad[h] = state.joints[h].angle_rad - g.held_rad[h];
    }
    for (Driven& j : driven) {
      if (!j.rejoining) continue;
      const double gap = q[j.q] - j.rejoin_rad;
      // Caught only with the controller wholly in command again (after the recovery's ramp).
      const bool ramped = state.time_s >= rejoin_from_s + scenario.lifecycle.recovery_ramp_s;
      if (ramped && std::abs(gap) <= step && std::abs(qd[j.q]) <= g.rejoin_rate_radps) {
        j.rejoining = false;  // caught: the person's reference from here on
        continue;
      }
      const double from = j.rejoin_rad, joint = state.joints[j.io].angle_rad;
      j.rejoin_rad = std::clamp(from + (std::abs(gap) <= step ? gap : std::copysign(step, gap)), joint - g.rejoin_lead_rad, joint + g.rejoin_lead_rad);
      q[j.q] = j.rejoin_rad;
      qd[j.q] = dt > 0 ? (j.rejoin_rad - from) / dt : 0.0;
      qdd[j.q] = 0.0;
    }
    for (const std::size_t h : torque_held) {
      double& x = hold_offset_rad[h];
      x = std::abs(x) <= step ? 0.0 : x - std::copysign(step, x);
    }
  }

  control::ArmController controller;
  /// An injected controller fault (sim/plant_faults.hpp: controller_nan) corrupts the command on its
  /// joint here, before the supervisor, as in E1 and E3.
  const sim::ControllerNanInjection controller_nan;
  const models::ArmModel& arm;
  models::ArmData arm_data;
  safety::JointModels joints;
  Eigen::VectorXd q, qd, qdd;   ///< the model's joints for the inverse dynamics
  std::vector<int> joints_q;    ///< model joint of each io joint
  std::vector<Driven> driven;
  std::vector<control::VelocityEstimator> encoder_velocity;  ///< per io joint: the rate the impedances damp
  double encoder_time_s = std::numeric_limits<double>::quiet_NaN();  ///< when encoder_velocity last read the encoders
  const std::vector<std::size_t> held;
  std::vector<std::size_t> torque_held;     ///< the held joints a torque drives (not a constant pressure)
  std::vector<double> hold_offset_rad;      ///< per io joint: a held joint's gap to its posture after a recovery, closing
  bool rejoin_pending = false;              ///< the operator recovered: take the gaps at the next step
  double rejoin_from_s = 0.0;               ///< the samples' clock when the last rejoin began
  double rejoin_time_s = std::numeric_limits<double>::quiet_NaN();  ///< the samples' clock at the last step
  std::vector<std::size_t> passive;         ///< io joints held at a constant pressure (the wrist)
  std::vector<double> passive_peak_speed_radps;  ///< per passive joint, after the release
  std::vector<std::vector<double>> held_q;  ///< per held joint and cycle, rad
  const std::vector<ReplayColumn> replay;   ///< the log's last block: what a replay needs besides the columns above
  safety::Envelope envelope;
  double peak_motor_torque_Nm = 0;
  std::vector<double> row;  ///< the log row, in goniometer_log_columns' order

 private:
  /// The encoders of the io joints into the model's joint vector (io and model indices differ once a
  /// body has passive joints before a driven one, or two arms).
  void encoders_into_q(const io::SensorState& state) {
    for (int j = 0; j < state.joint_count && j < static_cast<int>(joints_q.size()); ++j) {
      q[joints_q[static_cast<std::size_t>(j)]] = state.joints[static_cast<std::size_t>(j)].angle_rad;
    }
  }

  /// A goniometer sample: filter, differentiate, smooth the rate, estimate the acceleration; the un-smoothed command's
  /// inverse dynamics (the raw derivatives, held until the next sample).
  void sample_goniometers(const io::SensorState& state) {
    encoders_into_q(state);
    for (std::size_t n = 0; n < driven.size(); ++n) {
      Driven& j = driven[n];
      j.goniometer = readings[n](state.time_s);
      const double voluntary = j.tremor_model ? control::tremor_filter_step(*j.tremor_model, j.tremor, j.goniometer) : j.goniometer;
      j.d = j.derivative.step(voluntary);
      if (!j.sampled) {
        j.rate_smooth.reset(j.d.rate);
        j.sampled = true;
      }
      j.rate = j.rate_smooth.step(j.d.rate);
      control::update_motion_estimate(j.acceleration_estimator, j.motion, voluntary, state.time_s);
      j.sample_time_s = state.time_s;
      q[j.q] = j.d.value;
      qd[j.q] = j.d.rate;
      qdd[j.q] = j.d.acceleration;
    }
    const Eigen::VectorXd& tau = models::inverse_dynamics(arm, arm_data, q, qd, qdd);
    for (Driven& j : driven) j.tau_id_raw = tau[j.q];
  }

  /// The log row of cycle k, in goniometer_log_columns' order.
  void write_row(std::size_t k, const io::SensorState& state, const io::Command& sent, const sim::ArmTruth* tr, double tension_min_N) {
    using models::rad_to_deg;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double t = state.time_s;
    const bool operator_active = tr ? tr->operator_active : t < g.settle_s - 1.0;  // the operator lets go at settle_s - 1
    std::size_t c = 0;
    row[c++] = t;
    row[c++] = operator_active ? 1.0 : 0.0;
    for (const Driven& j : driven) {
      put_columns(row, c, DrivenAngleColumns{.person_elbow_deg = rad_to_deg(j.truth[k]), .goniometer_deg = rad_to_deg(j.goniometer),
                                             .filtered_elbow_deg = rad_to_deg(j.d.value), .filtered_rate_degps = rad_to_deg(j.rate),
                                             .filtered_accel_degps2 = rad_to_deg(j.motion.posterior.acceleration_radps2), .tau_elbow_cmd_Nm = j.tau_cmd,
                                             .plant_elbow_deg = tr ? rad_to_deg(j.exo[k]) : nan,
                                             .elbow_encoder_deg = rad_to_deg(state.joints[j.io].angle_rad)});
    }
    for (std::size_t h = 0; h < held.size(); ++h) {
      put_columns(row, c, HeldColumns{.plant_deg = rad_to_deg(held_q[h][k]), .tau_gravity_Nm = controller.diagnostics()[held[h]].torque_gravity_Nm});
    }
    for (const Driven& j : driven) {
      const io::JointSensors& s = state.joints[j.io];
      const io::JointCommand& cmd = sent.joints[j.io];
      put_columns(row, c, DrivenActuatorColumns{.tau_motor_cmd_Nm = cmd.motor_torque_Nm, .agonist_pressure_cmd_MPa = cmd.agonist_pressure_Pa * 1e-6,
                                                .antagonist_pressure_cmd_MPa = cmd.antagonist_pressure_Pa * 1e-6,
                                                .agonist_loadcell_N = s.agonist_loadcell_N, .antagonist_loadcell_N = s.antagonist_loadcell_N,
                                                .plant_agonist_force_N = tr ? tr->actuators[j.io].muscle_force_N[0] : nan,
                                                .plant_antagonist_force_N = tr ? tr->actuators[j.io].muscle_force_N[1] : nan,
                                                .plant_agonist_contraction = tr ? tr->actuators[j.io].muscle_contraction[0] : nan,
                                                .plant_antagonist_contraction = tr ? tr->actuators[j.io].muscle_contraction[1] : nan,
                                                .plant_agonist_pressure_MPa = tr ? tr->actuators[j.io].pressure_Pa[0] * 1e-6 : nan,
                                                .plant_antagonist_pressure_MPa = tr ? tr->actuators[j.io].pressure_Pa[1] * 1e-6 : nan});
    }
    row[c++] = tension_min_N;
    for (const ReplayColumn& r : replay) {
      const std::size_t n = hardware::kSensorColumns.size();
      row[c++] = r.field < n ? hardware::sensor_columns(state.joints[r.io])[r.field] : hardware::command_columns(sent.joints[r.io])[r.field - n];
    }
  }
};

/// RMS over cycles k0..done of what lies above `above_Hz` in `x` (sampled at fs_Hz): x minus its
/// zero-phase Butterworth low-pass (order 2 forward and backward: |H|^2 of order 4, -6 dB at above_Hz).
double high_frequency_rms(const std::vector<double>& x, double above_Hz, double fs_Hz, std::size_t k0, std::size_t done) {
  control::ButterworthFilter lp(2, above_Hz, fs_Hz);
  std::vector<double> y(done + 1);
  lp.reset(x[0]);
  for (std::size_t k = 0; k <= done; ++k) y[k] = lp.step(x[k]);
  lp.reset(y[done]);
  for (std::size_t k = done + 1; k-- > 0;) y[k] = lp.step(y[k]);
  double sum = 0.0;
  for (std::size_t k = k0; k <= done; ++k) sum += (x[k] - y[k]) * (x[k] - y[k]);
  return std::sqrt(sum / static_cast<double>(done - k0 + 1));
}

/// The lag (0..max_lag cycles) at which `late` best matches `early` over cycles k0..done: the peak of
/// their cross-covariance, normalised by the overlap.
std::size_t best_lag(const std::vector<double>& late, const std::vector<double>& early, std::size_t max_lag, std::size_t k0, std::size_t done) {
  double mean_late = 0.0, mean_early = 0.0;
  for (std::size_t k = k0; k <= done; ++k) mean_late += late[k], mean_early += early[k];
  mean_late /= static_cast<double>(done - k0 + 1);
  mean_early /= static_cast<double>(done - k0 + 1);
  std::size_t best = 0;
  double best_c = -std::numeric_limits<double>::infinity();
  for (std::size_t lag = 0; lag <= max_lag && k0 + lag < done; ++lag) {
    double c = 0.0;
    for (std::size_t k = k0 + lag; k <= done; ++k) c += (late[k] - mean_late) * (early[k - lag] - mean_early);
    c /= static_cast<double>(done - k0 - lag + 1);
    if (c > best_c) best_c = c, best = lag;
  }
  return best;
}

/// One driven joint's tracking from cycle k0 (the release) to `done`: the raw error, the lag that
/// best aligns the exoskeleton with the person, and its side's held joints' excursion.
GoniometerJointResult joint_tracking(const GoniometerRun& run, const Driven& j, std::size_t k0, std::size_t done) {
  const double period = run.scenario.period_s;
  const auto max_lag = static_cast<std::size_t>(std::llround(run.g.max_delay_s / period));
  GoniometerJointResult jr = j.r;
  jr.min_wire_tension_N = run.envelope.joints[j.io].min_tension_N;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
  for (std::size_t k = k0; k <= done; ++k) {
    const double e = j.exo[k] - j.truth[k];
    sum += e * e;
    jr.max_error_deg = std::max(jr.max_error_deg, models::rad_to_deg(std::abs(e)));
    lo = std::min(lo, j.truth[k]);
    hi = std::max(hi, j.truth[k]);
    for (std::size_t h = 0; h < run.held.size(); ++h) {  // the held joints of its own side
      if (side_of(arm_joint_names(run.scenario)[run.held[h]]) != side_of(jr.joint)) continue;
      jr.held_excursion_deg = std::max(jr.held_excursion_deg, models::rad_to_deg(std::abs(run.held_q[h][k] - run.held_q[h][k0])));
    }
  }
  jr.rms_error_deg = models::rad_to_deg(std::sqrt(sum / static_cast<double>(done - k0 + 1)));
  jr.range_deg = models::rad_to_deg(hi - lo);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t lag = 0; lag <= max_lag && k0 + lag < done; ++lag) {
    double s2 = 0.0;
    for (std::size_t k = k0 + lag; k <= done; ++k) {
      const double e = j.exo[k] - j.truth[k - lag];
      s2 += e * e;
    }
    const double rms = std::sqrt(s2 / static_cast<double>(done - k0 - lag + 1));
    if (rms < best) {
      best = rms;
      jr.delay_s = static_cast<double>(lag) * period;
    }
  }
  jr.rms_error_aligned_deg = models::rad_to_deg(best);
  jr.command_hf_rms_Nm = high_frequency_rms(j.command, run.g.command_hf_above_Hz, 1.0 / period, k0, done);
  jr.command_delay_s = static_cast<double>(best_lag(j.command, j.raw_command, max_lag, k0, done)) * period;
  return jr;
}

/// E4's figures and verdict from a run's buffers, `done` its last cycle.
GoniometerResult analyse_goniometer(const GoniometerRun& run, const std::string& name, GoniometerVariant variant, std::size_t done,
                                    const safety::FaultMonitor& monitor) {
  const ArmScenario& scenario = run.scenario;
  GoniometerResult r;
  r.name = name;
  r.variant = variant;
  r.filter_delay_s = run.driven.front().derivative.group_delay_s(0.0);
  r.peak_motor_torque_Nm = run.peak_motor_torque_Nm;
  r.peak_muscle_force_N = run.envelope.peak_muscle_force_N();
  r.min_wire_tension_N = run.envelope.min_tension_N();
  add_arm_envelope_checks(scenario, run.joints, run.envelope, r.verdict);
  // Tracking from the release to the end.
  const auto k0 = std::min(static_cast<std::size_t>(std::llround((run.g.settle_s - 1.0) / scenario.period_s)), done);
  for (const Driven& j : run.driven) {
    const GoniometerJointResult jr = joint_tracking(run, j, k0, done);
    r.verdict.at_most(jr.joint + " tracking RMS error", "deg", jr.rms_error_deg, scenario.verdict.max_tracking_rms_deg);
    r.verdict.at_most(jr.joint + " tracking max error", "deg", jr.max_error_deg, scenario.verdict.max_tracking_error_deg);
    r.verdict.at_most(fmt::format("{} torque command above {:g} Hz (RMS)", jr.joint, run.g.command_hf_above_Hz), "Nm", jr.command_hf_rms_Nm,
                      run.g.max_command_hf_rms_Nm);
    r.verdict.at_most(jr.joint + " torque command delay (smoothing)", "ms", jr.command_delay_s * 1e3, run.g.max_command_delay_s * 1e3);
    r.joints.push_back(jr);
  }
  for (std::size_t h = 0; h < run.held.size(); ++h) {
    double excursion_rad = 0.0;
    for (std::size_t k = k0; k <= done; ++k) excursion_rad = std::max(excursion_rad, std::abs(run.held_q[h][k] - run.held_q[h][k0]));
    r.held.push_back({arm_joint_names(scenario)[run.held[h]], models::rad_to_deg(excursion_rad)});
    r.verdict.at_most(r.held.back().joint + " held excursion", "deg", r.held.back().value, run.g.max_held_excursion_deg);
  }
  for (std::size_t p = 0; p < run.passive.size(); ++p) {
    r.passive.push_back({arm_joint_names(scenario)[run.passive[p]], models::rad_to_deg(run.passive_peak_speed_radps[p])});
    r.verdict.at_most(r.passive.back().joint + " passive peak speed", "deg/s", r.passive.back().value, run.g.max_passive_speed_degps);
  }
  r.fault_flags = monitor.flags();
  r.check_peaks = monitor.peaks();
  r.first_fault_flag = monitor.first().flag;
  safety::add_supervisor_check(monitor, r.verdict);
  r.within_limits = r.verdict.passed();
  return r;
}

}  // namespace

GoniometerResult run_goniometer_on(const ArmScenario& scenario, const std::string& name, GoniometerVariant variant, double duration_s,
                                   io::Backend& backend, sim::ArmBackend* sim, const std::vector<GoniometerSource>& readings,
                                   const std::vector<GoniometerSource>& persons, runtime::RowSink* log, const runtime::CycleHooks& hooks) {
  const ArmScenario::Goniometer& g = scenario.goniometer;
  if (readings.size() != g.joints.size() || (!persons.empty() && persons.size() != g.joints.size())) {
    throw std::invalid_argument(fmt::format("run_goniometer_on: {} readings and {} persons for {} driven joints", readings.size(),
                                            persons.size(), g.joints.size()));
  }
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  GoniometerRun run(scenario, variant, steps, readings, persons, sim);
  safety::LimitedBackend limited(backend, scenario.limits, run.joints);
  io::SensorState state;
  io::Command command;
  std::vector<runtime::LifecycleEvent> lifecycle;
  auto resume = [&run] {
    run.controller.resume();
    run.rejoin();
  };
  const runtime::CycleHooks loop_hooks =
      runtime::recording_lifecycle(runtime::resuming(runtime::with_lifecycle(hooks, scenario.lifecycle), resume), lifecycle);
  const auto wall_start = std::chrono::steady_clock::now();
  const std::size_t done = runtime::run_cycles(
      limited, loop_hooks, steps, state, command, [&](std::size_t k) { run.step(state, command, k); }, [&](std::size_t k) { run.hold(k); },
      [&](std::size_t k, const io::Command& sent, std::uint32_t) {
        // The person lets go of the arm only when the run is ready: every joint carried, no fault shown.
        if (sim) sim->keep_hands(!limited.monitor().ready(state.joint_count));
        run.observe(k, state, sent, log);
      });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  GoniometerResult r = analyse_goniometer(run, name, variant, done, limited.monitor());
  r.realtime_factor = duration_s / std::max(wall_s, 1e-9);
  r.lifecycle = std::move(lifecycle);
  return r;
}

}  // namespace peha::experiments
