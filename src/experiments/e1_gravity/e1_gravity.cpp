#include "peha/experiments/e1_gravity/e1_gravity.hpp"

#include "peha/calibration/sensor_corrections.hpp"
#include "peha/io/backend.hpp"
#include "peha/experiments/common/log_row.hpp"
#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/common/release_checks.hpp"
#include "peha/experiments/common/scenario_header.hpp"

#include "peha/models/model_config.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"
#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>

namespace peha::experiments {
namespace {

sim::FingerParams read_finger(config::Map map, double duration_s, std::vector<int>& probe_direction) {
  sim::FingerParams f;
  f.stiffness_N_per_m = map.number("stiffness_N_per_m", {1.0, 1e5});
  f.damping_Ns_per_m = map.number("damping_Ns_per_m", {0.0, 1e4});
  f.max_force_N = map.number("max_force_N", {0.0, 500.0});
  f.lever_m = map.number("lever_m", {0.01, 2.0});
  double previous_end = 0.0;
  for (config::Map push : map.maps("pushes", 1, 64)) {
    sim::FingerPush p;
    p.name = push.string("name");
    p.start_s = push.number("start_s", {0.0, duration_s});
    if (p.start_s < previous_end) push.fail("start_s", fmt::format("pushes must not overlap: the previous one ends at {} s", previous_end));
    p.duration_s = push.number("duration_s", {0.01, duration_s});
    p.hold = push.boolean_or("hold", false);
    int probe = 0;
    if (push.has("breakaway")) probe = push.choice("breakaway", {"up", "down"}) == "up" ? 1 : -1;
    if (p.hold) {
      p.move_s = p.duration_s;
      if (push.has("support")) {
        config::Map support = push.map("support");
        p.support_stiffness_N_per_m = support.number("stiffness_N_per_m", {1e3, 1e6});
        p.support_damping_Ns_per_m = support.number("damping_Ns_per_m", {0.0, 1e4});
        p.support_max_force_N = support.number("max_force_N", {1.0, 1e4});
        support.finish();
      }
    } else {
      p.move_s = push.number("move_s", {0.01, p.duration_s});
      p.target_angle_rad = models::deg_to_rad(push.number("target_angle_deg", {-90.0, 90.0}));
    }
    if (probe != 0 && p.hold) push.fail("breakaway", "a breakaway probe pushes one way: it cannot be a hold");
    push.finish();
    previous_end = p.start_s + p.duration_s;
    f.pushes.push_back(p);
    probe_direction.push_back(probe);
  }
  map.finish();
  return f;
}

}  // namespace

E1Scenario read_e1(const config::Document& doc) { return read_e1(doc, "gravity_compensation_1dof", {}); }

std::string e1_case_beyond_the_muscles(const E1Scenario& s, const E1Case& c) {
  const models::JointModel& joint = s.controller.joint;
  const control::OneDofGravityModel g = e1_controller_model(s, c).gravity;
  const safety::JointLimits& range = s.limits.joints[0];
  // Every angle of the range: a push or a safe state may leave the link anywhere in it, and a safe
  // state has no motor (it is off or a damper), so the lifting muscle alone must carry the payload.
  constexpr int kSteps = 90;
  for (int i = 0; i <= kSteps; ++i) {
    const double angle_rad = range.min_angle_rad + (range.max_angle_rad - range.min_angle_rad) * i / kSteps;
    const double torque_Nm = control::gravity_torque_Nm(g, angle_rad);
    const int lifter = torque_Nm >= 0 ? 0 : 1;  // the agonist lifts toward + angles
    const models::MuscleModel& m = lifter == 0 ? joint.agonist : joint.antagonist;
    const double eps = models::rigid_contraction(m, joint.pulley_radius_m, lifter == 0 ? +1 : -1, angle_rad);
    const double need_N = std::abs(torque_Nm) / joint.pulley_radius_m + joint.pretension_N;
    const double can_N = std::min(models::force_ceiling_N(m), models::forward_force_N(m.pam, joint.supply_pressure_Pa, eps));
    if (need_N > can_N) {
      const bool ceiling = can_N == models::force_ceiling_N(m);
      return fmt::format("holding {} kg at {:.0f} deg needs {:.0f} N of the {} (gravity {:.2f} Nm / pulley {} m + pretension {} N), more than "
                         "{}: the case is refused before arming - {}",
                         c.payload_kg, models::rad_to_deg(angle_rad), need_N, lifter == 0 ? "agonist" : "antagonist", torque_Nm,
                         joint.pulley_radius_m, joint.pretension_N,
                         ceiling ? fmt::format("its force ceiling of {:.0f} N", can_N)
                                 : fmt::format("the {:.0f} N its model makes there at the {:.2f} MPa supply", can_N, joint.supply_pressure_Pa * 1e-6),
                         ceiling ? "lighten the payload or narrow the range" : "lighten the payload, raise limits.supply_pressure_MPa or narrow the range");
    }
  }
  return {};
}

E1Scenario read_e1(const config::Document& doc, const char* experiment, const std::function<void(config::Map&)>& extra) {
  config::Map root = doc.root();
  E1Scenario s;
  const ScenarioHeader header = read_scenario_header(root, experiment);
  s.description = header.description;
  s.seed = header.seed;

  config::Map run = root.map("run");
  s.period_s = run.number("control_period_s", {1e-4, 0.1});
  s.duration_s = run.number("duration_s", {0.1, 3600.0});
  s.drift_window_s = run.number("drift_window_s", {0.1, 60.0});
  const double initial_angle = models::deg_to_rad(run.number("initial_angle_deg", {-90.0, 90.0}));
  run.finish();

  config::Map limits = root.map("limits");
  const double supply_Pa = limits.number("supply_pressure_MPa", {0.1, 1.0}) * 1e6;

  config::Map ctl = root.map("controller");
  double pretension_N = 0;
  s.controller.allocation = control::read_allocation(ctl.map("allocation"), pretension_N);
  s.controller.allocation.period_s = s.period_s;
  s.controller.joint = models::read_joint_model(ctl, "joint", supply_Pa, pretension_N);
  config::Map gravity = ctl.map("gravity");
  s.controller.gravity.link_mass_kg = gravity.number("link_mass_kg", {0.0, 50.0});
  s.controller.gravity.link_com_m = gravity.number("link_com_m", {0.0, 2.0});
  s.controller.gravity.payload_lever_m = gravity.number("payload_lever_m", {0.0, 2.0});
  s.controller.gravity.gravity_mps2 = gravity.number("gravity_mps2", {0.0, 20.0});
  gravity.finish();
  s.controller.velocity_cutoff_Hz = ctl.number("velocity_cutoff_Hz", {0.1, 500.0});
  if (ctl.has("creep_estimator")) s.controller.creep = control::read_creep_estimator(ctl.map("creep_estimator"));
  if (ctl.has("sensor_corrections")) use_sensor_corrections(s, ctl.path_value("sensor_corrections"));
  ctl.finish();

  s.limits = read_one_joint_limits(limits, s.period_s);

  config::Map plant = root.map("plant");
  s.plant = sim::read_one_dof_rig(plant, s.period_s, supply_Pa);
  s.plant.initial_angle_rad = initial_angle;
  s.plant.seed = s.seed;
  s.plant.finger = read_finger(root.map("finger"), s.duration_s, s.probe_direction);
  s.verdict = safety::read_verdict_thresholds(root);
  safety::read_monitor_params(root, s.limits.monitor);
  s.lifecycle = runtime::read_lifecycle(root);
  s.telemetry = runtime::read_telemetry(root);
  s.plant.faults = sim::read_plant_faults(root, sim::one_dof_rig_joint_names(), s.duration_s);

  for (config::Map c : root.maps("cases", 1, 16)) {
    E1Case e;
    e.name = c.string("name");
    e.payload_kg = c.number("payload_kg", {0.0, 20.0});
    const std::string refusal = e1_case_beyond_the_muscles(s, e);
    if (!refusal.empty()) c.fail("payload_kg", refusal);
    c.finish();
    s.cases.push_back(e);
  }
  if (root.has("mfb")) s.link = mfb::read_link_config(root.map("mfb"));
  if (root.has("calibration")) {
    config::Map cal = root.map("calibration");
    s.excitation[0] = experiments::read_excitation(cal.map("agonist"));
    s.excitation[1] = experiments::read_excitation(cal.map("antagonist"));
    if (cal.has("acceptance")) s.acceptance = experiments::read_calibration_acceptance(cal.map("acceptance"));
    cal.finish();
  }
  if (root.has("sensor_check")) s.sensor_check = read_sensor_check(root.map("sensor_check"));
  if (extra) extra(root);
  root.finish();
  return s;
}

const std::vector<std::string>& e1_log_columns() {
  static const std::vector<std::string> columns = {
      "t_s", "angle_rad", "velocity_radps", "finger_force_N", "finger_active",
      "tau_desired_Nm", "tau_pam_cmd_Nm", "tau_pam_measured_Nm", "tau_motor_cmd_Nm",
      "agonist_force_cmd_N", "antagonist_force_cmd_N", "agonist_loadcell_N", "antagonist_loadcell_N",
      "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa", "agonist_pressure_MPa", "antagonist_pressure_MPa",
      "plant_angle_rad", "plant_agonist_tension_N", "plant_antagonist_tension_N",
      "plant_agonist_force_N", "plant_antagonist_force_N", "plant_agonist_contraction", "plant_antagonist_contraction",
      "plant_cable_friction_Nm", "plant_constraint_Nm", "limit_flags", "fault_flags"};
  return columns;
}

void use_sensor_corrections(E1Scenario& scenario, const std::filesystem::path& path) {
  const calibration::SensorCorrections c = calibration::read_sensor_corrections(
      config::Document::load_file(path), scenario.controller.allocation.loadcell_check.max_tare_N);
  for (int i = 0; i < 2; ++i) scenario.controller.loadcell[i] = {c.loadcell_zero_N[i], c.loadcell_gain[i]};
  scenario.sensor_corrections_file = path;
}

void use_calibration_loadcell_zero(E1Scenario& scenario) { scenario.controller.allocation.loadcell_check.tare_s = 0.0; }

control::OneDofControllerModel e1_controller_model(const E1Scenario& scenario, const E1Case& c) {
  control::OneDofControllerModel m = scenario.controller;
  m.gravity.payload_mass_kg = c.payload_kg;
  return m;
}

sim::OneDofRigParams e1_plant_params(const E1Scenario& scenario, const E1Case& c) {
  sim::OneDofRigParams p = scenario.plant;
  p.payload_kg = c.payload_kg;
  return p;
}

hardware::HardwareRequest one_dof_rig_hardware(double period_s, const std::optional<mfb::LinkConfig>& link, const sim::OneDofRigParams& plant) {
  hardware::HardwareRequest r;
  r.period_s = period_s;
  r.joint_names = sim::one_dof_rig_joint_names();
  r.link = link ? &*link : nullptr;
  r.one_board = true;
  r.simulate = [plant]() -> std::unique_ptr<io::Backend> {
    const std::lock_guard lock(mujoco_load_mutex());  // MuJoCo's model loading is not thread-safe
    return std::make_unique<sim::OneDofRigBackend>(plant);
  };
  return r;
}

hardware::HardwareRequest e1_hardware(const E1Scenario& scenario, const E1Case& c) {
  return one_dof_rig_hardware(scenario.period_s, scenario.link, e1_plant_params(scenario, c));
}

sim::OneDofRigParams e1_recording_plant_params(const E1Scenario& scenario, sim::OneDofRigParams plant, int index) {
  const auto& e = scenario.excitation[index];
  if (!e) throw config::Error(fmt::format("no calibration.{} section (the excitation to run)", index == 0 ? "agonist" : "antagonist"));
  plant.payload_kg = e->payload_kg;
  plant.finger.pushes.clear();
  auto use_clamp = [&plant] {
    plant.finger.stiffness_N_per_m = kClampStiffness_N_per_m;
    plant.finger.damping_Ns_per_m = kClampDamping_Ns_per_m;
    plant.finger.max_force_N = kClampMaxForce_N;
  };
  // The load-cell tare: the link pinned at 0 while both muscles are vented (nobody holds it).
  if (e->excitation_start_s() > 0.0) {
    sim::FingerPush p;
    p.name = "clamp_tare";
    p.start_s = 0.0;
    p.duration_s = e->excitation_start_s();
    p.move_s = std::min(0.2, 0.5 * p.duration_s);
    p.target_angle_rad = 0.0;
    p.clamp = true;
    plant.finger.pushes.push_back(p);
    use_clamp();
  }
  // Clamped operating-point segments: the link pinned at the segment's angle while it runs.
  double segment_start_s = e->excitation_start_s() + e->duration_s;
  for (const ExcitationSegment& g : e->segments) {
    if (std::isfinite(g.clamp_angle_rad)) {
      sim::FingerPush p;
      p.name = fmt::format("clamp_{:.0f}deg", models::rad_to_deg(g.clamp_angle_rad));
      p.start_s = segment_start_s;
      p.duration_s = g.duration_s;
      p.move_s = std::min(1.0, 0.5 * g.duration_s);
      p.target_angle_rad = g.clamp_angle_rad;
      p.clamp = true;
      plant.finger.pushes.push_back(p);
      use_clamp();
    }
    segment_start_s += g.duration_s;
  }
  return plant;
}

safety::LimitsModel e1_recording_limits(const E1Scenario& scenario) {
  // The excitation drives one muscle far from the controller's model, the rig to its stops and a
  // wire near slack on purpose: only the checks of the hardware itself guard it (docs/safety.md:
  // the recording's swing is an open start-up problem).
  safety::LimitsModel limits = scenario.limits;
  limits.monitor.unmodelled = safety::kAllChecks & ~safety::kHardwareChecks;
  return limits;
}

hardware::HardwareRequest e1_recording_hardware(const E1Scenario& scenario, const sim::OneDofRigParams& plant, int index) {
  hardware::HardwareRequest r = one_dof_rig_hardware(scenario.period_s, scenario.link, e1_recording_plant_params(scenario, plant, index));
  r.drives_onto_stops = true;  // the excitation sweeps the link onto its stops
  return r;
}

calibration::Dataset record_e1_muscle(const E1Scenario& scenario, sim::OneDofRigParams plant, int index,
                                      const std::function<void(double)>& progress) {
  const hardware::Hardware rig = hardware::open_backend(hardware::BackendUri{}, e1_recording_hardware(scenario, plant, index));
  return record_excitation(*rig.backend, scenario.controller.joint, index == 0 ? +1 : -1, *scenario.excitation[index],
                           e1_recording_limits(scenario), progress, runtime::with_lifecycle({}, scenario.lifecycle));
}

double e1_plant_gravity_torque_Nm(const sim::OneDofRigParams& plant, double angle_rad) {
  // The same payload scaling as sim::OneDofRigBackend; a model is loaded per call (a few per case).
  sim::ModelPtr model = [&] {
    const std::lock_guard lock(mujoco_load_mutex());
    return sim::load_mjcf(plant.model_file);
  }();
  mjModel* m = model.get();
  const int payload = sim::require_id(m, mjOBJ_BODY, "payload", plant.model_file.string());
  const double payload_kg = plant.payload_kg + plant.unknown_payload_kg;  // what the plant really carries
  const double scale = payload_kg / m->body_mass[payload];
  m->body_mass[payload] = payload_kg;
  for (int i = 0; i < 3; ++i) m->body_inertia[3 * payload + i] *= scale;
  sim::DataPtr data(mj_makeData(m));
  mj_setConst(m, data.get());
  data->qpos[0] = angle_rad;
  mj_forward(m, data.get());
  return data->qfrc_bias[0];
}

E1Result run_e1_case(const E1Scenario& scenario, const E1Case& c, runtime::RowSink* log) {
  sim::OneDofRigBackend plant(e1_plant_params(scenario, c));
  return run_e1_on(scenario, c, plant, &plant, log);
}

namespace {

using io::kNaN;

/// What E1's loop records per cycle for the analysis after it; preallocated for the whole run.
struct E1Trace {
  std::vector<double> angle_rad;        ///< plant truth, else the encoder
  std::vector<char> finger_on;          ///< the finger touches the link (truth, else the schedule)
  std::vector<double> finger_force_N;   ///< plant truth (NaN without it)
  std::vector<double> constraint_Nm;    ///< plant truth: the torque MuJoCo's friction and limits hold
  double tracking_sum_N2[2] = {0, 0};   ///< sum of (force request - load cell)^2 per muscle after 1 s
  std::size_t tracking_count = 0;

  E1Trace(const E1Scenario& scenario, std::size_t steps)
      : angle_rad(steps + 1), finger_on(steps + 1), finger_force_N(steps + 1), constraint_Nm(steps + 1, kNaN) {
    // Without the simulator's truth, the finger is where the scenario's schedule puts it.
    for (std::size_t k = 0; k <= steps; ++k) {
      const double t = static_cast<double>(k) * scenario.period_s;
      for (const auto& push : scenario.plant.finger.pushes) finger_on[k] |= t >= push.start_s && t < push.start_s + push.duration_s;
    }
  }

  /// Static torque error at rest: what the friction holds, averaged over the last second before k1.
  double static_error_Nm(double period_s, std::size_t k1) const {
    const auto span = static_cast<std::size_t>(std::llround(1.0 / period_s));
    const std::size_t k0 = k1 > span ? k1 - span : 0;
    double sum = 0;
    for (std::size_t k = k0; k <= k1; ++k) sum += constraint_Nm[k];
    return -sum / static_cast<double>(k1 - k0 + 1);
  }
};

/// The envelope's sample of cycle `k` (plant truth when there is a simulator, else the sensors),
/// recorded into `trace`.
safety::JointSample observe_e1_sample(const io::JointSensors& s, const io::JointCommand& cmd, const sim::OneDofRigTruth* t, std::size_t k,
                                      E1Trace& trace) noexcept {
  if (t) {
    trace.angle_rad[k] = t->angle_rad;
    trace.finger_on[k] = t->finger_active;
    trace.finger_force_N[k] = t->finger_force_N;
    trace.constraint_Nm[k] = t->constraint_torque_Nm;
    return {{t->muscle_force_N[0], t->muscle_force_N[1]}, std::min(t->pulley_tension_min_N[0], t->pulley_tension_min_N[1]),
            {t->pressure_Pa[0], t->pressure_Pa[1]}, t->motor_torque_Nm, t->angle_rad};
  }
  trace.angle_rad[k] = s.angle_rad;
  trace.finger_force_N[k] = kNaN;
  return {{s.agonist_loadcell_N, s.antagonist_loadcell_N}, std::min(s.agonist_loadcell_N, s.antagonist_loadcell_N),
          {s.agonist_pressure_Pa, s.antagonist_pressure_Pa}, cmd.motor_torque_Nm, s.angle_rad};
}

/// E1's log row: e1_log_columns, the same names in order.
struct E1LogRow {
  double t_s, angle_rad, velocity_radps, finger_force_N, finger_active, tau_desired_Nm, tau_pam_cmd_Nm, tau_pam_measured_Nm,
      tau_motor_cmd_Nm, agonist_force_cmd_N, antagonist_force_cmd_N, agonist_loadcell_N, antagonist_loadcell_N, agonist_pressure_cmd_MPa,
      antagonist_pressure_cmd_MPa, agonist_pressure_MPa, antagonist_pressure_MPa, plant_angle_rad, plant_agonist_tension_N,
      plant_antagonist_tension_N, plant_agonist_force_N, plant_antagonist_force_N, plant_agonist_contraction,
      plant_antagonist_contraction, plant_cable_friction_Nm, plant_constraint_Nm, limit_flags,
      fault_flags;
};
using E1LogColumns = decltype(as_columns(E1LogRow{}));

/// One row of e1_log_columns().
void e1_log_row(const io::SensorState& state, const io::JointCommand& cmd, const control::OneDofDiagnostics& d, const sim::OneDofRigTruth* t,
                bool finger_on, std::uint32_t limit_flags, std::uint32_t fault_flags, E1LogColumns& row) noexcept {
  const io::JointSensors& s = state.joints[0];
  row = as_columns(E1LogRow{
      .t_s = state.time_s,
      .angle_rad = s.angle_rad,
      .velocity_radps = d.velocity_radps,
      .finger_force_N = t ? t->finger_force_N : kNaN,
      .finger_active = finger_on ? 1.0 : 0.0,
      .tau_desired_Nm = d.tau_desired_Nm,
      .tau_pam_cmd_Nm = d.allocation.tau_pam_cmd_Nm,
      .tau_pam_measured_Nm = d.allocation.tau_pam_measured_Nm,
      .tau_motor_cmd_Nm = cmd.motor_torque_Nm,
      .agonist_force_cmd_N = d.allocation.agonist_force_cmd_N,
      .antagonist_force_cmd_N = d.allocation.antagonist_force_cmd_N,
      .agonist_loadcell_N = s.agonist_loadcell_N,
      .antagonist_loadcell_N = s.antagonist_loadcell_N,
      .agonist_pressure_cmd_MPa = cmd.agonist_pressure_Pa * 1e-6,
      .antagonist_pressure_cmd_MPa = cmd.antagonist_pressure_Pa * 1e-6,
      .agonist_pressure_MPa = s.agonist_pressure_Pa * 1e-6,
      .antagonist_pressure_MPa = s.antagonist_pressure_Pa * 1e-6,
      .plant_angle_rad = t ? t->angle_rad : kNaN,
      .plant_agonist_tension_N = t ? t->pulley_tension_min_N[0] : kNaN,
      .plant_antagonist_tension_N = t ? t->pulley_tension_min_N[1] : kNaN,
      .plant_agonist_force_N = t ? t->muscle_force_N[0] : kNaN,
      .plant_antagonist_force_N = t ? t->muscle_force_N[1] : kNaN,
      .plant_agonist_contraction = t ? t->muscle_contraction[0] : kNaN,
      .plant_antagonist_contraction = t ? t->muscle_contraction[1] : kNaN,
      .plant_cable_friction_Nm = t ? t->cable_friction_Nm : kNaN,
      .plant_constraint_Nm = t ? t->constraint_torque_Nm : kNaN,
      .limit_flags = static_cast<double>(limit_flags),
      .fault_flags = static_cast<double>(fault_flags),
  });
}

/// The envelope's figures, the range reached and the supervisor's faults into `r` and its verdict.
void add_e1_envelope(const E1Scenario& scenario, const safety::JointModels& joints, const safety::Envelope& envelope,
                     const safety::LimitedBackend& limited, const E1Trace& trace, E1Result& r) {
  std::copy(std::begin(limited.data().counts), std::end(limited.data().counts), std::begin(r.limit_counts));
  const auto [lowest, highest] = std::minmax_element(trace.angle_rad.begin(), trace.angle_rad.end());
  r.min_angle_deg = models::rad_to_deg(*lowest);
  r.max_angle_deg = models::rad_to_deg(*highest);
  const safety::Envelope::Joint& e = envelope.joints[0];
  r.peak_muscle_force_N[0] = e.peak_muscle_force_N[0];
  r.peak_muscle_force_N[1] = e.peak_muscle_force_N[1];
  r.min_wire_tension_N = e.min_tension_N;
  r.max_pressure_MPa = e.max_pressure_Pa * 1e-6;
  r.peak_motor_torque_Nm = e.peak_motor_torque_Nm;
  r.verdict.thresholds = scenario.verdict;
  safety::add_envelope_checks(scenario.limits, joints, sim::one_dof_rig_joint_names(), envelope, scenario.verdict, r.verdict);
  r.fault_flags = limited.monitor().flags();
  r.faults = limited.monitor().count();
  r.fault_reason = limited.monitor().run_reason();
  r.check_peaks = limited.monitor().peaks();
  r.first_fault_flag = limited.monitor().first().flag;
  safety::add_supervisor_check(limited.monitor(), r.verdict);
}

int probe_of(const E1Scenario& scenario, std::size_t push) {
  return push < scenario.probe_direction.size() ? scenario.probe_direction[push] : 0;
}

/// Releases: the instants the finger lets go; drift over the window that follows, the distance to a
/// stop and (plant truth) the static torque error, each judged; then the peak finger force of the
/// pushes that move the link.
void add_e1_releases(const E1Scenario& scenario, const sim::OneDofRigParams& plant, const E1Trace& trace, std::size_t done, E1Result& r) {
  const safety::VerdictThresholds& th = scenario.verdict;
  const safety::JointLimits& range = scenario.limits.joints[0];
  const auto window = static_cast<std::size_t>(std::llround(scenario.drift_window_s / scenario.period_s));
  const auto& pushes = scenario.plant.finger.pushes;
  const std::vector<double>& angle = trace.angle_rad;
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    const auto& push = pushes[i];
    if (probe_of(scenario, i) != 0) continue;
    const auto k0 = static_cast<std::size_t>(std::llround((push.start_s + push.duration_s) / scenario.period_s));
    if (k0 > done) continue;
    E1Release rel;
    rel.push = push.name;
    rel.time_s = k0 * scenario.period_s;
    rel.angle_deg = models::rad_to_deg(angle[k0]);
    const std::size_t k1 = std::min(k0 + window, done);
    std::size_t last = k0;
    for (std::size_t k = k0; k <= k1 && !(k > k0 && trace.finger_on[k]); ++k) {
      rel.max_excursion_deg = std::max(rel.max_excursion_deg, models::rad_to_deg(std::abs(angle[k] - angle[k0])));
      rel.drift_deg = models::rad_to_deg(angle[k] - angle[k0]);
      last = k;
    }
    const StopDistance stop = stop_distance(angle, k0, last, range.min_angle_rad, range.max_angle_rad);
    rel.stop_distance_deg = stop.closest_deg;
    rel.gravity_torque_Nm = e1_plant_gravity_torque_Nm(plant, angle[last]);
    rel.static_torque_error_Nm = r.from_truth ? trace.static_error_Nm(scenario.period_s, last) : kNaN;
    rel.static_torque_error_pct = 100.0 * rel.static_torque_error_Nm / std::abs(rel.gravity_torque_Nm);
    r.releases.push_back(rel);

    add_release_checks(push.name, rel.drift_deg, rel.max_excursion_deg, stop, th, r.verdict);
    if (r.from_truth && std::abs(rel.gravity_torque_Nm) >= th.min_gravity_torque_Nm) {
      r.verdict.at_most(push.name + " |static torque error|", "% of gravity", std::abs(rel.static_torque_error_pct),
                        th.max_static_torque_error_pct);
    }
  }
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    const auto& push = pushes[i];
    if (push.hold || probe_of(scenario, i) != 0) continue;
    const auto k0 = static_cast<std::size_t>(std::llround(push.start_s / scenario.period_s));
    const auto k1 = static_cast<std::size_t>(std::llround((push.start_s + push.duration_s) / scenario.period_s));
    for (std::size_t k = k0; k <= std::min(k1, done); ++k) {
      r.peak_finger_force_N = std::max(r.peak_finger_force_N, std::abs(trace.finger_force_N[k]));
    }
  }
}

/// Breakaway probes: the finger force when the link has moved kBreakaway_deg from where the probe
/// began, up and down; their difference is the static torque error a person measures on hardware.
void add_e1_breakaway(const E1Scenario& scenario, const sim::OneDofRigParams& plant, const E1Trace& trace, std::size_t done, E1Result& r) {
  constexpr double kBreakaway_deg = 0.1;
  const auto& pushes = scenario.plant.finger.pushes;
  double force[2] = {kNaN, kNaN}, gravity[2] = {kNaN, kNaN}, truth[2] = {kNaN, kNaN};
  bool ran[2] = {false, false};
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    const int dir = probe_of(scenario, i);
    if (dir == 0 || !r.from_truth) continue;
    const int side = dir > 0 ? 0 : 1;
    const auto k0 = static_cast<std::size_t>(std::llround(pushes[i].start_s / scenario.period_s));
    const auto k1 = std::min(done, static_cast<std::size_t>(std::llround((pushes[i].start_s + pushes[i].duration_s) / scenario.period_s)));
    if (k0 == 0 || k0 > done) continue;
    ran[side] = true;
    gravity[side] = e1_plant_gravity_torque_Nm(plant, trace.angle_rad[k0 - 1]);
    truth[side] = 100.0 * trace.static_error_Nm(scenario.period_s, k0 - 1) / std::abs(gravity[side]);
    double peak = 0;
    for (std::size_t k = k0; k <= k1; ++k) {
      peak = std::max(peak, std::abs(trace.finger_force_N[k]));
      if (models::rad_to_deg(std::abs(trace.angle_rad[k] - trace.angle_rad[k0])) > kBreakaway_deg) {
        force[side] = peak;
        break;
      }
    }
  }
  if (!(ran[0] && ran[1])) return;
  E1Breakaway& b = r.breakaway;
  const double lever = scenario.plant.finger.lever_m;
  b.force_up_N = force[0];
  b.force_down_N = force[1];
  b.measured = !std::isnan(force[0]) && !std::isnan(force[1]);
  b.friction_band_Nm = (force[0] + force[1]) * lever / 2.0;
  b.torque_error_Nm = (force[1] - force[0]) * lever / 2.0;
  b.torque_error_pct = 100.0 * b.torque_error_Nm / (0.5 * (std::abs(gravity[0]) + std::abs(gravity[1])));
  b.truth_error_pct = 0.5 * (truth[0] + truth[1]);
}

}  // namespace

E1Result run_e1_on(const E1Scenario& scenario, const E1Case& c, io::Backend& backend, sim::OneDofRigBackend* sim,
                   runtime::RowSink* log, const runtime::CycleHooks& hooks) {
  const control::OneDofControllerModel model = e1_controller_model(scenario, c);
  control::OneDofGravityController controller(model);
  const safety::JointModels joints{&model.joint};  // the controller's joint set-up, shared with the limits
  safety::LimitedBackend limited(backend, scenario.limits, joints);
  safety::Envelope envelope;

  E1Result r;
  r.case_name = c.name;
  r.payload_kg = c.payload_kg;
  r.from_truth = sim != nullptr;

  const auto steps = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s));
  E1Trace trace(scenario, steps);
  io::SensorState state;
  io::Command command;
  E1LogColumns row{};
  const auto wall_start = std::chrono::steady_clock::now();
  auto hold = [&](std::size_t k) {  // no new sample: the command is held
    ++r.missed_samples;
    trace.angle_rad[k] = k > 0 ? trace.angle_rad[k - 1] : 0.0;
  };
  // An injected controller fault (sim/plant_faults.hpp: controller_nan) corrupts the command here,
  // before the supervisor: the test driver's part of the plant's fault injection.
  const sim::ControllerNanInjection controller_nan(scenario.plant.faults);
  auto step = [&](std::size_t) {
    controller.update(state, command);
    controller_nan.apply(state.time_s, command);
  };
  auto observe = [&](std::size_t k, const io::Command& sent, std::uint32_t flags) {
    const io::JointSensors& s = state.joints[0];
    const sim::OneDofRigTruth* t = sim ? &sim->sampled_truth() : nullptr;
    safety::JointSample j = observe_e1_sample(s, sent.joints[0], t, k, trace);
    // The start-up tare vents both muscles on purpose (the start pin holds the link): the wires are slack
    // until the tare is done and the muscles have filled again (refill_s). Their tension is not judged
    // then; every other figure is.
    const control::OneDofDiagnostics& d = controller.diagnostics();
    // The operator pulls the pin only when the run is ready: the joint carried, no fault shown.
    if (sim) sim->keep_support(!limited.monitor().ready(1));
    if (controller.wires_slack_on_purpose(state.time_s)) {
      j.min_tension_N = std::numeric_limits<double>::infinity();
      r.tare_slack_s = state.time_s;
    }
    r.loadcell_tare_N[0] = d.loadcell_offset_N[0];
    r.loadcell_tare_N[1] = d.loadcell_offset_N[1];
    envelope.observe(0, j);
    if (state.time_s >= 1.0) {  // after the start-up transient
      const double e1 = d.allocation.agonist_force_cmd_N - s.agonist_loadcell_N;
      const double e2 = d.allocation.antagonist_force_cmd_N - s.antagonist_loadcell_N;
      trace.tracking_sum_N2[0] += e1 * e1;
      trace.tracking_sum_N2[1] += e2 * e2;
      ++trace.tracking_count;
    }
    if (log) {
      e1_log_row(state, sent.joints[0], d, t, trace.finger_on[k], flags, limited.monitor().flags(), row);
      log->push_row(row);
    }
  };
  const runtime::CycleHooks loop_hooks = runtime::recording_lifecycle(
      runtime::resuming(runtime::with_lifecycle(hooks, scenario.lifecycle), [&controller] { controller.resume(); }), r.lifecycle);
  trace.angle_rad.resize(runtime::run_cycles(limited, loop_hooks, steps, state, command, step, hold, observe) + 1);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const std::size_t done = trace.angle_rad.size() - 1;  // a run ended early analyses what it has
  r.simulated_s = static_cast<double>(done) * scenario.period_s;
  for (int i = 0; i < 2; ++i) {
    r.force_tracking_rms_N[i] = trace.tracking_count ? std::sqrt(trace.tracking_sum_N2[i] / trace.tracking_count) : 0.0;
  }
  r.realtime_factor = r.simulated_s / std::max(wall_s, 1e-9);
  add_e1_envelope(scenario, joints, envelope, limited, trace, r);
  const sim::OneDofRigParams plant = sim ? sim->params() : e1_plant_params(scenario, c);
  if (r.tare_slack_s > 0) {
    const auto end = static_cast<std::size_t>(std::llround(r.tare_slack_s / scenario.period_s));
    safety::add_startup_checks("joint", trace.angle_rad, scenario.period_s, end, scenario.verdict, r.verdict);
  }
  add_e1_releases(scenario, plant, trace, done, r);
  add_e1_breakaway(scenario, plant, trace, done, r);
  r.within_limits = r.verdict.passed();
  if (!r.from_truth) r.peak_finger_force_N = kNaN;  // the finger is the simulator's secret
  return r;
}

}  // namespace peha::experiments
