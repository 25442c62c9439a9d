#include "peha/experiments/robustness/robustness.hpp"
#include "peha/io/backend.hpp"

#include "peha/experiments/common/job_pool.hpp"
#include "peha/models/exoskeleton.hpp"

#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/experiments/calibration_recording/acceptance.hpp"
#include "peha/calibration/gravity_identification.hpp"
#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/common/scenario_header.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e4_goniometer/goniometer.hpp"
#include "peha/experiments/sensor_check/sensor_check.hpp"
#include "peha/hardware/door.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>

namespace peha::experiments {
namespace {

/// E3's and E4's modes run the arm scenario; the others E1's.
bool is_arm(RobustnessMode m) noexcept {
  return m == RobustnessMode::kE3 || m == RobustnessMode::kE3Identified || m == RobustnessMode::kE4;
}
bool any_arm_mode(const std::vector<RobustnessMode>& modes) { return std::any_of(modes.begin(), modes.end(), is_arm); }
bool any_e1_mode(const std::vector<RobustnessMode>& modes) { return !std::all_of(modes.begin(), modes.end(), is_arm); }
bool has_mode(const std::vector<RobustnessMode>& modes, RobustnessMode m) { return std::find(modes.begin(), modes.end(), m) != modes.end(); }

using io::kNaN;

PlantVariant read_variant_keys(config::Map m) {
  PlantVariant v;
  v.name = m.string("name");
  v.cable_friction_scale = m.number_or("cable_friction_scale", 1.0, {0.0, 10.0});
  v.valve_time_scale = m.number_or("valve_time_scale", 1.0, {0.1, 10.0});
  v.muscle_strength_scale = m.number_or("muscle_strength_scale", 1.0, {0.1, 3.0});
  v.wire_stiffness_scale = m.number_or("wire_stiffness_scale", 1.0, {0.05, 10.0});
  v.loadcell_bias_N = m.number_or("loadcell_bias_N", 0.0, {-500.0, 500.0});
  v.agonist_loadcell_bias_N = m.number_or("agonist_loadcell_bias_N", 0.0, {-500.0, 500.0});
  v.antagonist_loadcell_bias_N = m.number_or("antagonist_loadcell_bias_N", 0.0, {-500.0, 500.0});
  v.agonist_loadcell_gain_scale = m.number_or("agonist_loadcell_gain_scale", 1.0, {0.5, 2.0});
  v.antagonist_loadcell_gain_scale = m.number_or("antagonist_loadcell_gain_scale", 1.0, {0.5, 2.0});
  v.pulley_radius_scale = m.number_or("pulley_radius_scale", 1.0, {0.5, 2.0});
  v.sensor_noise_scale = m.number_or("sensor_noise_scale", 1.0, {0.0, 100.0});
  v.link_mass_scale = m.number_or("link_mass_scale", 1.0, {0.1, 5.0});
  v.payload_scale = m.number_or("payload_scale", 1.0, {0.0, 5.0});
  v.extra_payload_kg = m.number_or("extra_payload_kg", 0.0, {0.0, 20.0});
  m.finish();
  return v;
}

/// A person of `e4.persons`: the arm scenario's movement by name (`movement: brisk`, with an optional
/// tremor) or its own (the keys of goniometer.movements), and its own arm's segments.
GoniometerPerson read_person(config::Map m) {
  GoniometerPerson p;
  if (m.has("movement")) {
    p.name = m.string("name");
    p.scenario_movement = m.string("movement");
    p.movement.name = p.name;
    p.movement.tremor_amplitude_rad = models::deg_to_rad(m.number_or("tremor_amplitude_deg", 0.0, {0.0, 20.0}));
    p.movement.tremor_frequency_Hz = m.number_or("tremor_frequency_Hz", 0.0, {0.0, 30.0});
    if ((p.movement.tremor_amplitude_rad > 0) != (p.movement.tremor_frequency_Hz > 0)) {
      m.fail("tremor_frequency_Hz", "a tremor needs both tremor_amplitude_deg and tremor_frequency_Hz above 0 (or neither)");
    }
  } else {
    // The driven joints' range is checked against the arm scenario when it is read (person_movement).
    p.movement = read_goniometer_movement(m, -180.0, 180.0);
    p.name = p.movement.name;
  }
  p.segment_length_scale = m.number_or("segment_length_scale", 1.0, {0.5, 2.0});
  p.segment_mass_scale = m.number_or("segment_mass_scale", 1.0, {0.2, 5.0});
  m.finish();
  return p;
}

/// `e4:` - the plant variants E4 runs on (by name), its paces (the arm scenario's movements) and persons.
E4Matrix read_e4(config::Map m, const std::vector<PlantVariant>& variants) {
  E4Matrix e;
  if (m.has("variants")) {
    std::vector<std::string> names;
    for (const PlantVariant& v : variants) names.push_back(v.name);
    e.variants = m.choices("variants", names, 1, names.size());
  }
  for (const std::string& pace : m.strings("paces", 1, 16)) {
    GoniometerPerson p;
    p.name = p.scenario_movement = pace;
    e.paces.push_back(p);
  }
  if (m.has("persons")) {
    for (config::Map p : m.maps("persons", 1, 64)) e.persons.push_back(read_person(p));
    if (std::none_of(variants.begin(), variants.end(), [](const PlantVariant& v) { return v.name == "nominal"; })) {
      m.fail("persons", "the persons run on the variant named nominal: add {name: nominal} to variants");
    }
  }
  m.finish();
  return e;
}

RobustnessGoal read_goal(config::Map m, RobustnessGoal g) {
  g.max_static_error_pct = m.number_or("max_static_torque_error_pct", g.max_static_error_pct, {0.0, 1000.0});
  g.min_tension_fraction = m.number_or("min_tension_fraction", g.min_tension_fraction, {0.0, 10.0});
  g.min_share = m.number_or("min_share", g.min_share, {0.0, 1.0});
  m.finish();
  return g;
}

/// Every cable, valve, muscle law and sensor of one joint under the variant.
void apply_to_joint(const PlantVariant& v, sim::PehaJointPlantParams& j) {
  for (sim::MusclePlantParams* m : {&j.agonist, &j.antagonist}) {
    m->cable.kinetic_friction *= v.cable_friction_scale;
    m->cable.static_friction *= v.cable_friction_scale;
    m->valve.dead_time_s *= v.valve_time_scale;
    m->valve.lag_s *= v.valve_time_scale;
    m->law.gain_N_per_Pa *= v.muscle_strength_scale;
    m->cable.wire_stiffness_N_per_m *= v.wire_stiffness_scale;
    m->loadcell_noise_N *= v.sensor_noise_scale;
    m->loadcell_offset_N += v.loadcell_bias_N;
  }
  j.agonist.loadcell_offset_N += v.agonist_loadcell_bias_N;
  j.antagonist.loadcell_offset_N += v.antagonist_loadcell_bias_N;
  j.agonist.loadcell_gain *= v.agonist_loadcell_gain_scale;
  j.antagonist.loadcell_gain *= v.antagonist_loadcell_gain_scale;
  j.pulley_radius_m *= v.pulley_radius_scale;
}

void scale_body(models::ArmBody& b, double s) {
  b.mass_kg *= s;
  b.inertia_kgm2 *= s;
}



/// The worst tension over the verdict's tension checks as a fraction of each joint's pretension.
double tension_fraction(const safety::Verdict& verdict) {
  double worst = std::numeric_limits<double>::infinity();
  const double fraction = verdict.thresholds.min_tension_fraction;
  for (const safety::Check& c : verdict.checks) {
    if (!c.figure.ends_with("lowest wire tension") || fraction <= 0) continue;
    worst = std::min(worst, c.value / (c.limit / fraction));
  }
  return worst;
}

std::string failures_of(const safety::Verdict& verdict) {
  std::string out;
  for (const safety::Check& c : verdict.checks) {
    if (!c.passed()) out += (out.empty() ? "" : "; ") + c.describe();
  }
  return out;
}

struct MatrixCase {
  RobustnessMode mode;
  const PlantVariant* variant;
  std::uint64_t seed;
  const GoniometerPerson* person = nullptr;  ///< E4 only
};

/// The controller of the calibrated mode: both muscles recorded and fitted on this variant's plant.
E1Scenario calibrated_on(const E1Scenario& nominal, const PlantVariant& v, std::uint64_t seed, const RobustnessConfig& config) {
  E1Scenario s = nominal;
  for (int i = 0; i < 2; ++i) {
    if (!s.excitation[i]) throw config::Error(fmt::format("{}: no calibration.{} section: the calibrated mode records it",
                                                          config.e1_config.string(), i == 0 ? "agonist" : "antagonist"));
    E1Case recording{"calibration", s.excitation[i]->payload_kg};
    sim::OneDofRigParams plant = e1_variant_plant(nominal, recording, v);
    plant.seed = seed;
    const calibration::Dataset data = record_e1_muscle(nominal, plant, i);
    calibration::CalibrateOptions o;
    o.muscle = i == 0 ? "agonist" : "antagonist";
    o.fit.restarts = config.calibration_restarts;
    o.fit.threads = 1;  // the matrix runs cases in parallel instead
    o.fit.seed = seed;
    o.spgp.num_pseudo = config.calibration_pseudo_inputs;
    o.spgp.max_iterations = config.calibration_spgp_iterations;
    o.spgp.seed = seed;
    const calibration::CalibrationOutcome outcome = calibration::calibrate(data, o);
    if (!config.keep_calibrations_dir.empty()) {
      const std::filesystem::path stem = config.keep_calibrations_dir / fmt::format("{}-seed{}-{}", v.name, seed, o.muscle);
      calibration::write_dataset(stem.string() + ".csv", data,
                                 {fmt::format("recorded by peha robustness on variant {} (seed {})", v.name, seed)});
      // The kept file names the CSV beside it, so it reads back as a checked calibration file.
      calibration::MuscleCalibration kept = outcome.calibration;
      kept.data_file = stem.filename().string() + ".csv";
      kept.data_sha256 = calibration::sha256_file(stem.string() + ".csv");
      calibration::write_calibration(stem.string() + ".yaml", kept);
    }
    // The same checks a calibration file passes before use (a refusal is this variant's result).
    const safety::JointLimits& range = s.limits.joints[0];
    calibration::apply_calibration(outcome.calibration, fmt::format("calibration of {} on variant {}", o.muscle, v.name), true,
                                   s.controller.joint, i, range.min_angle_rad, range.max_angle_rad);
  }
  s.controller.allocation.force_trim_rate_1ps = 0.0;  // the paper's pure feed-forward
  use_calibration_loadcell_zero(s);
  if (s.acceptance) {
    // The closed-loop check on the variant's rig (as `peha calibrate --scenario` runs it on the rig).
    const AcceptanceResult check = run_acceptance_check(s, *s.acceptance, [&](const E1Scenario& sc, const E1Case& c) {
      sim::OneDofRigParams p = e1_variant_plant(sc, c, v);
      p.seed = seed;
      return p;
    });
    std::string failed;
    for (int i = 0; i < 2; ++i) {
      if (!check.passed(i)) failed += (failed.empty() ? "" : "; ") + check.failure(i);
    }
    if (!failed.empty()) throw calibration::CalibrationRejected("closed-loop check on the rig: " + failed);
  }
  return s;
}

RobustnessRow e1_row(const E1Scenario& scenario, const E1Case& c, const PlantVariant& v, std::uint64_t seed) {
  sim::OneDofRigParams plant_params = e1_variant_plant(scenario, c, v);
  plant_params.seed = seed;
  std::unique_ptr<sim::OneDofRigBackend> plant;
  {
    const std::lock_guard lock(mujoco_load_mutex());
    plant = std::make_unique<sim::OneDofRigBackend>(plant_params);
  }
  const E1Result r = run_e1_on(scenario, c, *plant, plant.get(), nullptr);
  RobustnessRow row;
  row.payload = c.name;
  row.static_error_pct = 0;
  for (const E1Release& rel : r.releases) {
    row.static_error_pct = std::max(row.static_error_pct, std::abs(rel.static_torque_error_pct));
    row.drift_deg = std::max(row.drift_deg, std::abs(rel.drift_deg));
  }
  row.breakaway_error_pct = r.breakaway.measured ? r.breakaway.torque_error_pct : kNaN;
  row.min_tension_N = r.min_wire_tension_N;
  row.tension_fraction = tension_fraction(r.verdict);
  row.verdict = r.within_limits;
  row.failures = failures_of(r.verdict);
  return row;
}

/// Each case's row when the procedure before E1 (a calibration, the sensor check) refused the variant:
/// no figures, the reason as its failure (judge_rows names the variant, mode and seed).
std::vector<RobustnessRow> refused_rows(const E1Scenario& nominal, const std::vector<std::size_t>& cases, const std::string& reason) {
  std::vector<RobustnessRow> rows;
  for (std::size_t c : cases) {
    RobustnessRow row;
    row.payload = nominal.cases[c].name;
    row.static_error_pct = row.breakaway_error_pct = row.drift_deg = row.min_tension_N = row.tension_fraction = kNaN;
    row.failures = reason;
    rows.push_back(row);
  }
  return rows;
}

/// One E1 job: every selected case of one variant and seed (the calibrated mode calibrates once for all).
std::vector<RobustnessRow> run_e1_job(const E1Scenario& nominal, const MatrixCase& job, const std::vector<std::size_t>& cases,
                                      const RobustnessConfig& config) {
  std::vector<RobustnessRow> rows;
  E1Scenario scenario = nominal;
  if (job.mode == RobustnessMode::kE1CalibratedFF) {
    try {
      scenario = calibrated_on(nominal, *job.variant, job.seed, config);
    } catch (const calibration::CalibrationRejected& e) {
      // A calibration the checks refuse is never run: the variant fails, and says why.
      return refused_rows(nominal, cases, std::string("calibration refused: ") + e.what());
    }
  }
  if (job.mode == RobustnessMode::kE1SensorChecked) {
    if (!nominal.sensor_check) throw std::invalid_argument("e1_sensor_checked: the E1 scenario has no sensor_check: section");
    // Checked as a lab would on the rig: the variant's sensors, cables and link, with the check's known
    // mass on the link instead of a case's payload (which the check does not see).
    PlantVariant rig = *job.variant;
    rig.payload_scale = 1.0;
    rig.extra_payload_kg = 0.0;
    sim::OneDofRigParams plant = e1_variant_plant(nominal, nominal.cases.front(), rig);
    plant.seed = job.seed;
    try {
      const SensorCheckResult check = check_sensors(nominal, *nominal.sensor_check, plant, nominal.sensor_check->known_mass_kg);
      for (int i = 0; i < 2; ++i) {
        scenario.controller.loadcell[i] = {check.corrections.loadcell_zero_N[i], check.corrections.loadcell_gain[i]};
      }
    } catch (const SensorCheckRejected& e) {
      // A check that refuses the sensors (a zero below the channel's range) leaves them uncorrected:
      // the variant fails, and says why.
      return refused_rows(nominal, cases, std::string("sensor check refused: ") + e.what());
    }
  }
  for (std::size_t c : cases) rows.push_back(e1_row(scenario, nominal.cases[c], *job.variant, job.seed));
  return rows;
}

RobustnessRow run_e3_job(const ArmScenario& nominal, const MatrixCase& job) {
  ArmScenario scenario = nominal;
  if (job.mode == RobustnessMode::kE3Identified) {
    // Identified on this variant's arm as the user would on the rig - before picking up the hand's
    // unknown payload, which the identification therefore does not see.
    PlantVariant before_payload = *job.variant;
    before_payload.extra_payload_kg = 0.0;
    sim::ArmPlantParams rig = arm_variant_plant(nominal, before_payload);
    rig.seed = job.seed;
    try {
      scenario.controller.arm = identify_arm_gravity(scenario, rig).identified;
    } catch (const calibration::GravityIdentificationRejected& e) {
      RobustnessRow row;
      row.payload = "mannequin";
      row.static_error_pct = row.breakaway_error_pct = row.drift_deg = row.min_tension_N = row.tension_fraction = kNaN;
      row.failures = std::string("identification refused: ") + e.what();
      return row;
    }
  }
  scenario.plant = arm_variant_plant(nominal, *job.variant);
  scenario.plant.seed = scenario.seed = job.seed;
  std::unique_ptr<sim::ArmBackend> plant;
  {
    const std::lock_guard lock(mujoco_load_mutex());
    plant = std::make_unique<sim::ArmBackend>(postures_plant_params(scenario));
  }
  const PosturesResult r = run_postures_on(scenario, *plant, plant.get(), nullptr);
  RobustnessRow row;
  row.payload = "mannequin";
  row.breakaway_error_pct = kNaN;
  for (const PostureResult& p : r.postures) {
    for (const PostureJointResult& j : p.joints) {
      row.drift_deg = std::max(row.drift_deg, std::abs(j.drift_deg));
      // Worst static torque error (truth) over postures and joints that carry a judged gravity torque.
      if (std::abs(j.gravity_torque_Nm) >= scenario.verdict.min_gravity_torque_Nm) {
        row.static_error_pct = std::max(row.static_error_pct, std::abs(j.static_torque_error_pct));
        const double model = std::abs(j.model_gravity_error_pct);
        row.model_gravity_error_pct = std::isnan(row.model_gravity_error_pct) ? model : std::max(row.model_gravity_error_pct, model);
      }
    }
  }
  row.min_tension_N = r.min_wire_tension_N;
  row.tension_fraction = tension_fraction(r.verdict);
  row.verdict = r.within_limits;
  row.failures = failures_of(r.verdict);
  return row;
}

/// E4 on one variant's plant with one person: the feedback variant (the one judged; the paper's pure
/// replay fails its tracking figures on the nominal plant). Physics forbids the verdict, before the run,
/// when the person moves faster than the supervisor lets any joint move, or when a tremor alone puts
/// the tracking RMS past its limit.
RobustnessRow run_e4_job(const ArmScenario& nominal, const MatrixCase& job) {
  const GoniometerPerson& person = *job.person;
  ArmScenario scenario = nominal;
  scenario.plant = arm_variant_plant(nominal, *job.variant);
  scale_user_arm(scenario.plant, person.segment_length_scale, person.segment_mass_scale);
  scenario.plant.seed = scenario.seed = job.seed;
  const ArmScenario::Goniometer& g = scenario.goniometer;
  // The goniometer's noise as `peha run` draws it for the scenario's k-th movement (seed + k).
  std::uint64_t noise_seed = job.seed;
  for (std::size_t k = 0; k < g.movements.size(); ++k) {
    if (g.movements[k].name == person.scenario_movement) noise_seed += k;
  }
  std::vector<GoniometerTrace> traces = synthesize_goniometers(g, person_movement(nominal, person), noise_seed);
  for (GoniometerTrace& t : traces) t.name = person.name;
  const hardware::Hardware hw =
      hardware::open_backend(hardware::BackendUri{}, goniometer_hardware(scenario, goniometer_plant_params(scenario, traces)));
  const GoniometerResult r = run_goniometer(scenario, traces, GoniometerVariant::kFeedback, hw, nullptr);
  RobustnessRow row;
  row.payload = person.name;
  row.static_error_pct = row.breakaway_error_pct = row.drift_deg = kNaN;
  const GoniometerJointResult& j = r.joints.front();
  row.e4.rms_error_deg = j.rms_error_deg;
  row.e4.max_error_deg = j.max_error_deg;
  row.e4.delay_ms = 1e3 * j.delay_s;
  row.e4.command_hf_rms_Nm = j.command_hf_rms_Nm;
  row.e4.held_excursion_deg = j.held_excursion_deg;
  row.e4.passive_speed_degps = 0;
  for (const GoniometerJointFigure& p : r.passive) row.e4.passive_speed_degps = std::max(row.e4.passive_speed_degps, p.value);
  double peak_radps = 0;
  const std::vector<double>& q = traces.front().truth_rad;
  for (std::size_t k = 1; k < q.size(); ++k) peak_radps = std::max(peak_radps, std::abs(q[k] - q[k - 1]) * g.sample_rate_Hz);
  row.e4.person_speed_degps = models::rad_to_deg(peak_radps);
  // The judged wires (the wrist's constant-pressure pair has no tension floor).
  row.min_tension_N = kNaN;
  for (const safety::Check& c : r.verdict.checks) {
    if (c.figure.ends_with("lowest wire tension")) row.min_tension_N = std::isnan(row.min_tension_N) ? c.value : std::min(row.min_tension_N, c.value);
  }
  row.tension_fraction = tension_fraction(r.verdict);
  row.verdict = r.within_limits;
  row.failures = failures_of(r.verdict);
  // The supervisor's first fault is the cause; the figures that fail after its safe state are its effects.
  if (r.first_fault_flag != 0) row.failures = fmt::format("first fault {}; {}", safety::fault_flag_name(r.first_fault_flag), row.failures);
  const double speed_limit_degps = models::rad_to_deg(scenario.limits.monitor.max_joint_speed_radps);
  const double tremor_rms_deg = models::rad_to_deg(person_movement(nominal, person).tremor_amplitude_rad) / std::sqrt(2.0);
  if (row.e4.person_speed_degps > speed_limit_degps) {
    row.physics_reason = fmt::format("the person moves at {:.0f} deg/s, faster than the supervisor lets any joint move ({:.0f} deg/s)",
                                     row.e4.person_speed_degps, speed_limit_degps);
  } else if (tremor_rms_deg > scenario.verdict.max_tracking_rms_deg) {
    row.physics_reason = fmt::format("the tremor alone is {:.1f} deg RMS, above the {:.1f} deg tracking limit, and no arm follows it",
                                     tremor_rms_deg, scenario.verdict.max_tracking_rms_deg);
  }
  return row;
}

const RobustnessGoal& goal_of(const RobustnessConfig& c, RobustnessMode m) {
  switch (m) {
    case RobustnessMode::kE1Default: return c.goal_default;
    case RobustnessMode::kE1CalibratedFF: return c.goal_calibrated;
    case RobustnessMode::kE1SensorChecked: return c.goal_sensor_checked;
    case RobustnessMode::kE3: return c.goal_e3;
    case RobustnessMode::kE3Identified: return c.goal_e3_identified;
    case RobustnessMode::kE4: break;  // its verdict, not a static error (required_share)
  }
  return c.goal_default;
}

double required_share(const RobustnessConfig& c, RobustnessMode m) {
  return m == RobustnessMode::kE4 ? c.e4_min_share : goal_of(c, m).min_share;
}

}  // namespace

PlantVariant read_plant_variant(config::Map m) { return read_variant_keys(std::move(m)); }

const char* to_string(RobustnessMode m) {
  switch (m) {
    case RobustnessMode::kE1Default: return "e1_default";
    case RobustnessMode::kE1CalibratedFF: return "e1_calibrated_ff";
    case RobustnessMode::kE1SensorChecked: return "e1_sensor_checked";
    case RobustnessMode::kE3: return "e3_postures";
    case RobustnessMode::kE3Identified: return "e3_identified";
    case RobustnessMode::kE4: return "e4_goniometer";
  }
  return "?";
}

std::string robustness_mode_names() {
  std::string names;
  for (RobustnessMode m : kRobustnessModes) names += (names.empty() ? "" : ", ") + std::string(to_string(m));
  return names;
}

RobustnessConfig read_robustness(const config::Document& doc) {
  config::Map root = doc.root();
  RobustnessConfig c;
  const ScenarioHeader header = read_scenario_header(root, "robustness");
  config::Map modes = root.map("modes");
  for (RobustnessMode m : kRobustnessModes) {
    if (modes.boolean_or(to_string(m), false)) c.modes.push_back(m);
  }
  modes.finish();
  if (c.modes.empty()) root.fail("modes", "no mode is on: set one of " + robustness_mode_names() + " to true");
  // Each scenario is needed by the modes that run it only (a matrix of E3 modes names no E1 scenario).
  if (any_e1_mode(c.modes) || root.has("e1_scenario")) c.e1_config = root.path_value("e1_scenario");
  if (any_arm_mode(c.modes) || root.has("arm_scenario")) c.arm_config = root.path_value("arm_scenario");
  if (root.has("seeds")) {
    for (double s : root.numbers("seeds", {0.0, 1e9}, 1, 16)) c.seeds.push_back(static_cast<std::uint64_t>(s));
  } else {
    c.seeds = {header.seed};
  }
  if (root.has("e1_case")) c.e1_cases = {root.string("e1_case")};
  c.threads = static_cast<int>(root.integer("threads", 1, 64));
  if (std::find(c.modes.begin(), c.modes.end(), RobustnessMode::kE1CalibratedFF) != c.modes.end() || root.has("calibration_restarts")) {  // the calibrated mode's settings
    c.calibration_restarts = static_cast<int>(root.integer("calibration_restarts", 1, 1000));
    c.calibration_pseudo_inputs = static_cast<int>(root.integer("calibration_pseudo_inputs", 5, 500));
    c.calibration_spgp_iterations = static_cast<int>(root.integer("calibration_spgp_iterations", 1, 10000));
  }
  c.e1_duration_s = root.number_or("e1_duration_s", 0.0, {0.0, 3600.0});
  if (root.has("goals")) {
    config::Map goals = root.map("goals");
    if (goals.has("e1_default")) c.goal_default = read_goal(goals.map("e1_default"), c.goal_default);
    if (goals.has("e1_calibrated_ff")) c.goal_calibrated = read_goal(goals.map("e1_calibrated_ff"), c.goal_calibrated);
    if (goals.has("e1_sensor_checked")) c.goal_sensor_checked = read_goal(goals.map("e1_sensor_checked"), c.goal_sensor_checked);
    if (goals.has("e3_postures")) c.goal_e3 = read_goal(goals.map("e3_postures"), c.goal_e3);
    if (goals.has("e3_identified")) c.goal_e3_identified = read_goal(goals.map("e3_identified"), c.goal_e3_identified);
    if (goals.has("e4_goniometer")) {
      config::Map e4 = goals.map("e4_goniometer");  // its verdict's figures are the arm scenario's
      c.e4_min_share = e4.number("min_share", {0.0, 1.0});
      e4.finish();
    }
    goals.finish();
  }
  for (config::Map v : root.maps("variants", 1, 256)) c.variants.push_back(read_variant_keys(v));
  if (has_mode(c.modes, RobustnessMode::kE4) || root.has("e4")) c.e4 = read_e4(root.map("e4"), c.variants);
  root.finish();
  return c;
}

sim::OneDofRigParams e1_variant_plant(const E1Scenario& scenario, const E1Case& c, const PlantVariant& v) {
  sim::OneDofRigParams p = e1_plant_params(scenario, c);
  apply_to_joint(v, p.joint);
  p.pressure_noise_Pa *= v.sensor_noise_scale;
  // The link's mass as the payload with the same gravity torque (the link's inertia stays; its
  // share of the rig's inertia is small): m_link l_com (s - 1) / l_payload.
  double link_moment_kgm = 0, payload_lever_m = 0;
  {
    const std::lock_guard lock(mujoco_load_mutex());
    const sim::ModelPtr model = sim::load_mjcf(p.model_file);
    const int link = sim::require_id(model.get(), mjOBJ_BODY, "link", p.model_file.string());
    const int payload = sim::require_id(model.get(), mjOBJ_BODY, "payload", p.model_file.string());
    link_moment_kgm = model->body_mass[link] * model->body_ipos[3 * link];
    payload_lever_m = model->body_pos[3 * payload] + model->body_ipos[3 * payload];
  }
  // The controller keeps the case's payload; the plant gets the difference as the payload it is not told.
  p.unknown_payload_kg += c.payload_kg * (v.payload_scale - 1.0) + v.extra_payload_kg +
                          (v.link_mass_scale - 1.0) * link_moment_kgm / payload_lever_m;
  return p;
}

sim::ArmPlantParams arm_variant_plant(const ArmScenario& scenario, const PlantVariant& v) {
  sim::ArmPlantParams p = scenario.plant;
  for (auto& j : p.actuators) apply_to_joint(v, j);
  p.pressure_noise_Pa *= v.sensor_noise_scale;
  for (models::ArmBody& b : p.model.bodies) {
    // "exo_forearm", or "R_exo_forearm" on a body with both arms.
    const std::string_view role = models::without_side(b.name);
    if (role.starts_with("exo_")) scale_body(b, v.link_mass_scale);
    if (role.starts_with("user_")) scale_body(b, v.payload_scale);
  }
  p.unknown_hand_payload_kg += v.extra_payload_kg;
  return p;
}

namespace {

}  // namespace

void scale_user_arm(sim::ArmPlantParams& p, double length_scale, double mass_scale) {
  for (models::ArmBody& b : p.model.bodies) {
    if (!models::without_side(b.name).starts_with("user_")) continue;
    scale_body(b, mass_scale);
    b.com_m *= length_scale;
    b.inertia_kgm2 *= length_scale * length_scale;
  }
}

ArmScenario::Goniometer::Movement person_movement(const ArmScenario& scenario, const GoniometerPerson& person) {
  const ArmScenario::Goniometer& g = scenario.goniometer;
  ArmScenario::Goniometer::Movement m = person.movement;
  if (!person.scenario_movement.empty()) {
    const auto it = std::find_if(g.movements.begin(), g.movements.end(),
                                 [&](const ArmScenario::Goniometer::Movement& s) { return s.name == person.scenario_movement; });
    if (it == g.movements.end()) {
      throw config::Error(fmt::format("E4 person {}: the arm scenario has no goniometer movement named {}", person.name,
                                      person.scenario_movement));
    }
    m = *it;
    m.name = person.name;
    if (person.movement.tremor_amplitude_rad > 0) {
      m.tremor_amplitude_rad = person.movement.tremor_amplitude_rad;
      m.tremor_frequency_Hz = person.movement.tremor_frequency_Hz;
    }
  }
  for (const int j : g.joints) {
    const auto& lim = scenario.limits.joints[static_cast<std::size_t>(j)];
    for (const double end : {m.from_rad, m.to_rad}) {
      for (const double a : {end - m.tremor_amplitude_rad, end + m.tremor_amplitude_rad}) {
        if (a < lim.min_angle_rad || a > lim.max_angle_rad) {
          throw config::Error(fmt::format("E4 person {}: reaches {:.1f} deg, outside the driven joint's range [{:.1f}, {:.1f}] deg",
                                          person.name, models::rad_to_deg(a), models::rad_to_deg(lim.min_angle_rad),
                                          models::rad_to_deg(lim.max_angle_rad)));
        }
      }
    }
  }
  return m;
}

RobustnessScenarios read_robustness_scenarios(const RobustnessConfig& config) {
  RobustnessScenarios s;
  if (any_e1_mode(config.modes)) {
    s.e1 = read_e1(config::Document::load_file(config.e1_config));
    if (config.e1_duration_s > 0) s.e1.duration_s = config.e1_duration_s;
    for (std::size_t i = 0; i < s.e1.cases.size(); ++i) {
      if (config.e1_cases.empty() || std::find(config.e1_cases.begin(), config.e1_cases.end(), s.e1.cases[i].name) != config.e1_cases.end()) {
        s.cases.push_back(i);
      }
    }
    if (s.cases.empty()) throw config::Error(fmt::format("{}: none of e1_cases is a case of the E1 scenario", config.e1_config.string()));
  }
  if (any_arm_mode(config.modes)) s.arm = read_arm_scenario(config::Document::load_file(config.arm_config));
  if (has_mode(config.modes, RobustnessMode::kE4)) {
    for (const auto* list : {&config.e4.paces, &config.e4.persons}) {
      for (const GoniometerPerson& p : *list) person_movement(s.arm, p);  // throws naming the person
    }
  }
  return s;
}

namespace {

/// Every mode x variant x seed, the calibrated jobs first: they take longest (two recordings and two
/// fits each).
std::vector<MatrixCase> robustness_jobs(const RobustnessConfig& config) {
  std::vector<MatrixCase> jobs;
  for (RobustnessMode mode : config.modes) {
    for (const PlantVariant& v : config.variants) {
      for (std::uint64_t seed : config.seeds) {
        if (mode != RobustnessMode::kE4) {
          jobs.push_back({mode, &v, seed});
          continue;
        }
        // E4: every pace on its variants, and its persons on the nominal plant.
        const auto& names = config.e4.variants;
        if (names.empty() || std::find(names.begin(), names.end(), v.name) != names.end()) {
          for (const GoniometerPerson& p : config.e4.paces) jobs.push_back({mode, &v, seed, &p});
        }
        if (v.name == "nominal") {
          for (const GoniometerPerson& p : config.e4.persons) jobs.push_back({mode, &v, seed, &p});
        }
      }
    }
  }
  std::stable_sort(jobs.begin(), jobs.end(), [](const MatrixCase& a, const MatrixCase& b) {
    return (a.mode == RobustnessMode::kE1CalibratedFF) > (b.mode == RobustnessMode::kE1CalibratedFF);
  });
  return jobs;
}

/// A zero below the channel's bottom reads code 0 vented whatever its size (-20 N or -300 N): the
/// start-up's `loadcell_zero` and the sensor check refuse it, and only the amplifier's offset, set
/// on the hardware, removes it. That refusal is the designed outcome, not a control defect; a run
/// that did not refuse stays judged by its figures.
void refused_zero_below_channel(const PlantVariant& v, RobustnessRow& row) {
  if (row.goal || !v.zero_below_channel() || !row.physics_reason.empty()) return;
  const std::string& f = row.failures;  // the first fault (or the sensor check's refusal) must be the zero's
  if (f.find("first: loadcell_zero") == std::string::npos && f.find("first fault loadcell_zero") == std::string::npos &&
      f.find("reads code 0") == std::string::npos)
    return;
  row.physics_reason =
      "a load-cell zero below its channel's bottom reads code 0 vented: no controller can see it; peha refuses the start-up and the "
      "amplifier's offset must be re-set on the hardware";
}

/// A job's rows named (variant, mode, seed) and judged against its mode's goal, with physics' reason
/// where no controller without position feedback can meet it; `seconds` the job's wall time.
void judge_rows(const RobustnessConfig& config, const MatrixCase& job, double seconds, std::vector<RobustnessRow>& rows) {
  const RobustnessGoal& g = goal_of(config, job.mode);
  for (RobustnessRow& row : rows) {
    row.variant = job.variant->name;
    row.mode = to_string(job.mode);
    row.seed = job.seed;
    row.seconds = seconds / static_cast<double>(rows.size());
    if (job.mode == RobustnessMode::kE4) {
      // E4 feeds the elbow's angle back: an untold gravity or no cable friction is not out of its reach
      // (run_e4_job names what is). Its goal is its verdict.
      row.goal = row.verdict;
      refused_zero_below_channel(*job.variant, row);
      row.physics_forbids = !row.physics_reason.empty();
      continue;
    }
    // A gravity the controller cannot know: the variant's unknown payload or mass. Its own model's
    // error (E3's arm model) is not physics: identification on the rig removes it, so it counts.
    // After an identification on the variant, only the payload picked up afterwards is unknown.
    const bool untold_gravity = job.mode == RobustnessMode::kE3Identified ? job.variant->extra_payload_kg != 0
                                                                           : job.variant->changes_gravity();
    if (untold_gravity) {
      row.physics_reason =
          "plant gravity the controller is not told: without position feedback a target error below the mismatch is out of reach";
    } else if (job.variant->removes_friction()) {
      row.physics_reason =
          "no cable friction: without position feedback any error of the gravity model moves the joint (a neutral equilibrium)";
    }
    const bool error_ok = row.static_error_pct <= g.max_static_error_pct;
    row.goal = error_ok && row.tension_fraction >= g.min_tension_fraction;
    refused_zero_below_channel(*job.variant, row);
    row.physics_forbids = !row.physics_reason.empty();
  }
}

using RobustnessProgress = std::function<void(std::size_t, std::size_t, const std::string&)>;

/// Runs the jobs on config.threads threads, job i's rows into element i, each row reported to
/// `progress` as it is done. A job's exception stops the others and is rethrown.
std::vector<std::vector<RobustnessRow>> run_jobs(const RobustnessConfig& config, const RobustnessScenarios& scenarios,
                                                 const std::vector<MatrixCase>& jobs, const RobustnessProgress& progress) {
  std::size_t total = 0;
  for (const MatrixCase& j : jobs) total += is_arm(j.mode) ? 1 : scenarios.cases.size();
  std::vector<std::vector<RobustnessRow>> rows_of(jobs.size());
  std::size_t done = 0;
  std::mutex report;
  run_job_pool(jobs.size(), config.threads, [&](std::size_t i) {
    const MatrixCase& job = jobs[i];
    const auto start = std::chrono::steady_clock::now();
    std::vector<RobustnessRow> rows;
    if (job.mode == RobustnessMode::kE4) {
      rows.push_back(run_e4_job(scenarios.arm, job));
    } else if (is_arm(job.mode)) {
      rows.push_back(run_e3_job(scenarios.arm, job));
    } else {
      rows = run_e1_job(scenarios.e1, job, scenarios.cases, config);
    }
    judge_rows(config, job, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), rows);
    const std::lock_guard lock(report);
    for (const RobustnessRow& row : rows) {
      const std::size_t n = ++done;
      if (progress && job.mode == RobustnessMode::kE4) {
        progress(n, total,
                 fmt::format("{:<17} {:<22} {:<14} seed {}: RMS {:>5.2f} deg, max {:>5.1f} deg, delay {:>3.0f} ms, command > 10 Hz {:.3f} Nm, "
                             "shoulder {:.2f} deg, wrist {:>4.0f} deg/s, T_min {:>5.1f} N, verdict {} ({:.0f} s)",
                             row.mode, row.variant, row.payload, row.seed, row.e4.rms_error_deg, row.e4.max_error_deg, row.e4.delay_ms,
                             row.e4.command_hf_rms_Nm, row.e4.held_excursion_deg, row.e4.passive_speed_degps, row.min_tension_N,
                             row.verdict ? "OK" : "FAIL", row.seconds));
      } else if (progress) {
        progress(n, total,
                 fmt::format("{:<17} {:<22} {:<14} seed {}: static error {:>6.1f} %, drift {:>8.3f} deg, T_min/pretension {:>5.2f}, "
                             "verdict {}, goal {} ({:.0f} s)",
                             row.mode, row.variant, row.payload, row.seed, row.static_error_pct, row.drift_deg, row.tension_fraction,
                             row.verdict ? "OK" : "FAIL", row.goal ? "met" : "missed", row.seconds));
      }
    }
    rows_of[i] = std::move(rows);
  });
  return rows_of;
}

/// Per mode, how many of its rows met the goal, and how many of those that missed it physics forbids.
std::vector<RobustnessResult::Share> goal_shares(const RobustnessConfig& config, const std::vector<RobustnessRow>& rows) {
  std::vector<RobustnessResult::Share> shares;
  for (RobustnessMode mode : config.modes) {
    RobustnessResult::Share s{to_string(mode), 0, 0, 0, required_share(config, mode)};
    for (const RobustnessRow& r : rows) {
      if (r.mode != s.mode) continue;
      ++s.total;
      s.met += r.goal;
      s.forbidden += r.physics_forbids && !r.goal;
    }
    shares.push_back(s);
  }
  return shares;
}

}  // namespace

RobustnessResult run_robustness(const RobustnessConfig& config,
                                const std::function<void(std::size_t, std::size_t, const std::string&)>& progress) {
  return run_robustness(config, read_robustness_scenarios(config), progress);
}

RobustnessResult run_robustness(const RobustnessConfig& config, const RobustnessScenarios& scenarios,
                                const std::function<void(std::size_t, std::size_t, const std::string&)>& progress) {
  const std::vector<MatrixCase> jobs = robustness_jobs(config);
  std::vector<std::vector<RobustnessRow>> rows_of = run_jobs(config, scenarios, jobs, progress);
  // The table in the configuration's order: mode, variant, seed, case.
  RobustnessResult result;
  for (RobustnessMode mode : config.modes) {
    for (const PlantVariant& v : config.variants) {
      for (std::uint64_t seed : config.seeds) {
        for (std::size_t i = 0; i < jobs.size(); ++i) {  // E4's persons in their order after its paces
          if (jobs[i].mode == mode && jobs[i].variant == &v && jobs[i].seed == seed) {
            result.rows.insert(result.rows.end(), rows_of[i].begin(), rows_of[i].end());
          }
        }
      }
    }
  }
  result.shares = goal_shares(config, result.rows);
  return result;
}

void write_robustness(const std::filesystem::path& dir, const RobustnessConfig& config, const RobustnessResult& result) {
  std::ofstream csv(dir / "robustness.csv");
  csv << "mode,variant,payload,seed,static_torque_error_pct,breakaway_error_pct,drift_deg,min_tension_N,tension_fraction,"
         "verdict,goal,physics_forbids,model_gravity_error_pct,e4_rms_error_deg,e4_max_error_deg,e4_delay_ms,e4_command_hf_rms_Nm,"
         "e4_held_excursion_deg,e4_passive_speed_degps,e4_person_speed_degps,seconds,failures\n";
  for (const RobustnessRow& r : result.rows) {
    std::string failures = r.failures;
    std::replace(failures.begin(), failures.end(), ',', ' ');
    std::replace(failures.begin(), failures.end(), '"', '\'');
    csv << fmt::format("{},{},{},{},{:.3f},{:.3f},{:.4f},{:.2f},{:.3f},{},{},{},{:.3f},{:.3f},{:.2f},{:.1f},{:.4f},{:.3f},{:.1f},{:.1f},{:.1f},\"{}\"\n",
                       r.mode, r.variant, r.payload, r.seed, r.static_error_pct, r.breakaway_error_pct, r.drift_deg, r.min_tension_N,
                       r.tension_fraction, r.verdict ? 1 : 0, r.goal ? 1 : 0, r.physics_forbids ? 1 : 0, r.model_gravity_error_pct,
                       r.e4.rms_error_deg, r.e4.max_error_deg, r.e4.delay_ms, r.e4.command_hf_rms_Nm, r.e4.held_excursion_deg,
                       r.e4.passive_speed_degps, r.e4.person_speed_degps, r.seconds, failures);
  }
  std::ofstream md(dir / "robustness.md");
  md << "# Robustness matrix\n\n";
  std::string scenarios;
  if (!config.e1_config.empty()) scenarios += fmt::format("E1 scenario `{}`, ", config.e1_config.filename().string());
  if (!config.arm_config.empty()) scenarios += fmt::format("arm scenario `{}`, ", config.arm_config.filename().string());
  md << fmt::format("{}seeds {}; {} variants. Variants change only the plant.\n\n", scenarios, fmt::join(config.seeds, ", "),
                    config.variants.size());
  md << "Goals: ";
  for (RobustnessMode m : config.modes) {
    if (m == RobustnessMode::kE4) {
      md << fmt::format("e4_goniometer its verdict (every figure of E4, the arm scenario's thresholds) in >= {:.0f} % of the cases; ",
                        100 * config.e4_min_share);
      continue;
    }
    const RobustnessGoal& g = goal_of(config, m);
    md << fmt::format("{} |static torque error| <= {} % and T_min >= {} x pretension in >= {:.0f} % of the variants; ", to_string(m),
                      g.max_static_error_pct, g.min_tension_fraction, 100 * g.min_share);
  }
  md << "E3's static torque error is from the arm's truth, every gravity-compensated joint.\n\n";
  md << "The share is judged over the cases physics allows; cases where physics forbids the goal to a controller without position "
        "feedback (plant gravity the controller is not told; no cable friction to hold a model error) are in the table, marked with "
        "the reason, and fail their verdict.\n\n";
  md << "| mode | goal met, of the cases physics allows | physics forbids (goal missed, reported) | goal met, of all cases | required |\n"
        "|---|---|---|---|---|\n";
  for (const auto& s : result.shares) {
    md << fmt::format("| {} | {}/{} ({:.0f} %) | {} | {}/{} | {:.0f} % {} |\n", s.mode, s.met, s.judged(),
                      s.judged() ? 100.0 * s.met / s.judged() : 0.0, s.forbidden, s.met, s.total, 100 * s.required,
                      s.ok() ? "met" : "**missed**");
  }
  md << "\n| variant | payload | mode | seed | static torque error % | breakaway estimate % | worst drift deg | T_min N | T_min / pretension "
        "| verdict | goal | note |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto num = [](double v, const char* f) { return std::isnan(v) ? std::string("-") : fmt::format(fmt::runtime(f), v); };
  for (const RobustnessRow& r : result.rows) {
    if (r.mode == to_string(RobustnessMode::kE4)) continue;  // its own table below
    std::string note;
    if (r.physics_forbids) note = r.physics_reason;
    if (!std::isnan(r.model_gravity_error_pct) && r.model_gravity_error_pct > config.goal_e3.max_static_error_pct) {  // E3 rows only
      note += fmt::format("{}the controller's gravity model is {:.1f} % off the plant's (identify it on the rig)", note.empty() ? "" : "; ",
                          r.model_gravity_error_pct);
    }
    if (!r.verdict) {
      std::string first = r.failures.substr(0, r.failures.find(';'));
      note += (note.empty() ? "" : "; ") + first;
    }
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {:.3f} | {:.1f} | {:.2f} | {} | {} | {} |\n", r.variant, r.payload, r.mode, r.seed,
                      num(r.static_error_pct, "{:.1f}"), num(r.breakaway_error_pct, "{:.1f}"), r.drift_deg, r.min_tension_N,
                      r.tension_fraction, r.verdict ? "OK" : "FAIL", r.goal ? "met" : "missed", note);
  }
  // E4: its own figures; a failed case says whether physics forbids it (with the number) or the control fails.
  if (!has_mode(config.modes, RobustnessMode::kE4)) return;
  md << "\n## E4, the goniometer-driven elbow (feedback variant)\n\n"
        "Person: a pace of the arm scenario on each variant's plant, or a person of `e4.persons` on the nominal plant. Figures "
        "from the release on (plant truth): tracking RMS / max / delay of the exoskeleton's elbow behind the person's, the torque "
        "command above 10 Hz, the held shoulder's excursion, the passive wrist's peak speed, the lowest wire.\n\n"
        "| variant | person | person's peak deg/s | RMS deg | max deg | delay ms | command > 10 Hz Nm | shoulder deg | wrist deg/s "
        "| T_min N | verdict | cause |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const RobustnessRow& r : result.rows) {
    if (r.mode != to_string(RobustnessMode::kE4)) continue;
    std::string cause = "-";
    if (!r.verdict) {
      cause = (r.physics_forbids ? "physics forbids: " + r.physics_reason : std::string("control defect (physics allows it)")) + ": " +
              r.failures.substr(0, r.failures.find(';'));
    }
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} | {} | {} |\n", r.variant, r.payload,
                      num(r.e4.person_speed_degps, "{:.0f}"), num(r.e4.rms_error_deg, "{:.2f}"), num(r.e4.max_error_deg, "{:.1f}"),
                      num(r.e4.delay_ms, "{:.0f}"), num(r.e4.command_hf_rms_Nm, "{:.3f}"), num(r.e4.held_excursion_deg, "{:.2f}"),
                      num(r.e4.passive_speed_degps, "{:.0f}"), r.min_tension_N, r.verdict ? "OK" : "FAIL", cause);
  }
}

}  // namespace peha::experiments
