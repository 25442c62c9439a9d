#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/common/scenario_header.hpp"

#include "peha/calibration/gravity_identification.hpp"

#include "peha/models/exoskeleton.hpp"
#include "peha/control/butterworth.hpp"
#include "peha/models/model_config.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <complex>
#include <cmath>
#include <limits>

namespace peha::experiments {
namespace {

/// Pressure and rate limits of the `limits:` section (shared by every actuated joint).
struct ArmLimits {
  double supply_Pa = 0, rate_Pa_per_s = 0, motor_rate_Nm_per_s = 0;
};

/// The body's driven joints in io order: every side, each side's active joints in list order.
struct IoJoint {
  std::string name;        ///< "R_SFE"
  std::size_t driven = 0;  ///< its arm joint's index in driven_arm_joints (the `joints:` entry it uses)
  int model_joint = 0;     ///< index into the ArmModel
};

std::vector<IoJoint> io_joints(const models::ExoskeletonSpec& body) {
  std::vector<IoJoint> out;
  int model_joint = 0;
  for (const models::ArmSide side : body.sides) {
    std::size_t driven = 0;
    for (const models::ArmJointSpec& j : body.arm_joints) {
      if (j.active) out.push_back({fmt::format("{}_{}", models::side_prefix(side), j.name), driven++, model_joint});
      ++model_joint;
    }
  }
  return out;
}

/// The arm joints that are driven (each once, in list order): the keys of `joints:`.
std::vector<std::string> driven_arm_joints(const models::ExoskeletonSpec& body) {
  std::vector<std::string> out;
  for (const models::ArmJointSpec& j : body.arm_joints) {
    if (j.active) out.push_back(j.name);
  }
  return out;
}

/// `controller:`: the nominal arm, the allocation, and per driven joint (`joints: {<name>: ...}`, applied
/// to every side) its actuator kind, model and limits.
void read_arm_controller(config::Map ctl, const models::BodyConfig& body, const ArmLimits& l, ArmScenario& s) {
  s.controller.arm = s.nominal_arm = body.controller.model();
  // Optional: the arm's gravity parameters identified on the rig (peha identify-gravity).
  if (ctl.has("gravity_identification")) s.gravity_identification_file = ctl.path_value("gravity_identification");
  s.controller.velocity_cutoff_Hz = ctl.number("velocity_cutoff_Hz", {0.1, 500.0});
  double pretension_N = 0;
  s.controller.allocation = control::read_allocation(ctl.map("allocation"), pretension_N);
  if (ctl.has("creep_estimator")) s.controller.creep = control::read_creep_estimator(ctl.map("creep_estimator"));
  s.controller.allocation.period_s = s.period_s;
  const std::vector<IoJoint> io = io_joints(body.controller);
  if (io.empty() || io.size() > static_cast<std::size_t>(io::kMaxJoints)) {
    ctl.fail("joints", fmt::format("the body drives {} joints; peha drives 1 to {}", io.size(), io::kMaxJoints));
  }
  s.limits.joint_count = static_cast<int>(io.size());
  s.limits.period_s = s.period_s;
  config::Map joints = ctl.map("joints");
  std::vector<control::ArmActuatedJoint> per_arm_joint;
  std::vector<std::pair<double, double>> range_rad;
  for (const std::string& name : driven_arm_joints(body.controller)) {
    config::Map j = joints.map(name);
    control::ArmActuatedJoint joint;
    const std::string kind = j.choice("actuator", {"peha", "pam_pair", "constant_pressure"});
    const double lo = models::deg_to_rad(j.number("min_angle_deg", {-180.0, 180.0}));
    const double hi = models::deg_to_rad(j.number("max_angle_deg", {models::rad_to_deg(lo), 180.0}));
    if (kind == "constant_pressure") {
      joint.mode = control::ArmJointMode::kHoldPressure;
      joint.hold_pressure_Pa = j.number("hold_pressure_MPa", {0.0, l.supply_Pa * 1e-6}) * 1e6;
    }
    joint.actuator = models::read_joint_model(j, name, l.supply_Pa, pretension_N);
    if (joint.actuator.has_motor != (kind == "peha")) {
      j.fail("has_motor", fmt::format("actuator '{}' {} a motor, found has_motor: {}", kind, kind == "peha" ? "has" : "has no",
                                      joint.actuator.has_motor));
    }
    j.finish();
    per_arm_joint.push_back(joint);
    range_rad.emplace_back(lo, hi);
  }
  joints.finish();
  for (std::size_t i = 0; i < io.size(); ++i) {
    const std::size_t k = io[i].driven;
    control::ArmActuatedJoint joint = per_arm_joint[k];
    joint.model_joint = io[i].model_joint;
    joint.actuator.name = io[i].name;
    safety::JointLimits& lim = s.limits.joints[i];
    lim.pressure_rate_Pa_per_s = l.rate_Pa_per_s;
    lim.motor_rate_Nm_per_s = l.motor_rate_Nm_per_s;
    lim.min_angle_rad = range_rad[k].first;
    lim.max_angle_rad = range_rad[k].second;
    s.controller.joints.push_back(joint);
  }
  ctl.finish();
}

/// `plant:` and `operator:`: the simulated arm, its actuators (`joints: {<name>: ...}`, every side) and
/// the operator's hands.
void read_arm_plant(config::Map plant, config::Map op, const models::BodyConfig& body, const ArmLimits& l, ArmScenario& s) {
  sim::ArmPlantParams& p = s.plant;
  p.model = body.plant.model();
  p.mjcf = sim::exoskeleton_mjcf_options(body.plant);
  p.timestep_s = sim::read_timestep_s(plant, s.period_s);
  p.mjcf.timestep_s = p.timestep_s;
  p.control_period_s = s.period_s;
  p.encoder_counts_per_rev = plant.number("encoder_counts_per_rev", {16, 1e9});
  p.joint_encoder_counts_per_rev = plant.number_or("joint_encoder_counts_per_rev", 0.0, {0, 1e9});
  p.unknown_hand_payload_kg = plant.number_or("unknown_hand_payload_kg", 0.0, {-20.0, 20.0});  // plant-only
  config::Map pressure = plant.map("pressure_sensor");
  p.pressure_noise_Pa = pressure.number("noise_MPa", {0.0, 0.1}) * 1e6;
  p.pressure_range_Pa = pressure.number("range_MPa", {0.1, 2.0}) * 1e6;
  pressure.finish();
  // Initial angles by arm joint (every side), 0 for joints not named.
  config::Map q0 = plant.map("initial_angles_deg");
  std::vector<double> per_arm;
  for (const models::ArmJointSpec& j : body.plant.arm_joints) {
    const double default_deg = j.locked ? models::rad_to_deg(j.locked_at_rad) : 0.0;
    const config::Range range_deg{models::rad_to_deg(j.min_angle_rad), models::rad_to_deg(j.max_angle_rad)};
    per_arm.push_back(models::deg_to_rad(q0.number_or(j.name, default_deg, range_deg)));
  }
  q0.finish();
  for (std::size_t side = 0; side < body.plant.sides.size(); ++side) p.initial_q_rad.insert(p.initial_q_rad.end(), per_arm.begin(), per_arm.end());
  config::Map joints = plant.map("joints");
  std::vector<sim::PehaJointPlantParams> per_arm_joint;
  const std::vector<std::string> driven = driven_arm_joints(body.plant);
  for (std::size_t k = 0; k < driven.size(); ++k) {
    config::Map j = joints.map(driven[k]);
    // The plant's motor is where the controller's model says the joint has one (the first side's io
    // joints are the driven joints in this order).
    per_arm_joint.push_back(sim::read_peha_joint_plant(j, l.supply_Pa, s.controller.joints[k].actuator.has_motor));
    j.finish();
  }
  joints.finish();
  for (const IoJoint& j : io_joints(body.plant)) {
    p.actuated.push_back(j.name);
    p.actuators.push_back(per_arm_joint[j.driven]);
  }
  plant.finish();
  p.seed = s.seed;

  p.operator_hands.stiffness_Nm_per_rad = op.number("stiffness_Nm_per_rad", {0.0, 1e4});
  p.operator_hands.damping_Nms_per_rad = op.number("damping_Nms_per_rad", {0.0, 1e3});
  p.operator_hands.max_torque_Nm = op.number("max_torque_Nm", {0.0, 200.0});
  op.finish();
}

/// A per-joint map: a value per driven joint, by arm joint ("SFE": every side) or by io joint ("R_SFE":
/// that side only, over the arm joint's value), joint i's within range(i); NaN for joints not named.
template <class RangeOf>
std::vector<double> read_joint_map(config::Map& item, const ArmScenario& s, RangeOf range) {
  std::vector<double> v(s.plant.actuated.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string& io_name = s.plant.actuated[i];
    const std::string_view arm_name = models::without_side(io_name);
    if (item.has(io_name)) {
      v[i] = item.number(io_name, range(i));
    } else if (item.has(arm_name)) {
      v[i] = item.number(arm_name, range(i));
    }
  }
  item.finish();
  return v;
}

/// An `angles_deg:` map (read_joint_map, in rad): each within its joint's range. Joints not named stay
/// NaN (the operator leaves them free). At least `min_named` joints must be named.
std::vector<double> read_angles(config::Map item, const ArmScenario& s, std::size_t min_named) {
  std::vector<double> q = read_joint_map(item, s, [&](std::size_t i) {
    const safety::JointLimits& lim = s.limits.joints[i];
    return config::Range{models::rad_to_deg(lim.min_angle_rad), models::rad_to_deg(lim.max_angle_rad)};
  });
  std::size_t named = 0;
  for (double& v : q) {
    v = models::deg_to_rad(v);
    named += !std::isnan(v);
  }
  if (named < min_named) item.fail("", fmt::format("names {} joints, needs at least {}", named, min_named));
  return q;
}

/// `postures:` (E3): the script, each posture within the joint ranges.
void read_postures(config::Map postures, ArmScenario& s) {
  s.move_s = postures.number("move_s", {0.1, 60.0});
  s.hold_s = postures.number("hold_s", {0.0, 60.0});
  s.observe_s = postures.number("observe_s", {0.1, 600.0});
  for (config::Map item : postures.maps("list", 1, 32)) {
    ArmPosture a;
    a.name = item.string("name");
    a.target_rad = read_angles(item.map("angles_deg"), s, 1);
    item.finish();
    s.postures.push_back(a);
  }
  postures.finish();
}

/// An io joint named in `key` of `section` (E4's `joints:`, E6's `joint:`) that a torque command can
/// drive: a peha or pam_pair joint, not one held at a constant pressure. Returns its io index.
int torque_driven_joint(const config::Map& section, std::string_view key, const std::string& name, const ArmScenario& s) {
  const std::vector<std::string>& io = s.plant.actuated;
  const auto i = static_cast<std::size_t>(std::find(io.begin(), io.end(), name) - io.begin());
  if (s.controller.joints[i].mode == control::ArmJointMode::kHoldPressure) {
    section.fail(key, fmt::format("expected a joint with a peha or pam_pair actuator, found {} (actuator constant_pressure: held at "
                                  "a constant pressure, no torque command)", name));
  }
  return static_cast<int>(i);
}

/// `bandwidth:` (E6): the swept joint, the locked posture and the sweep.
void read_bandwidth(config::Map bw, ArmScenario& s) {
  s.bandwidth.joint = torque_driven_joint(bw, "joint", bw.choice("joint", s.plant.actuated), s);
  // The bench locks every joint the posture names; the swept joint must be one of them.
  s.bandwidth.locked_rad = read_angles(bw.map("angles_deg"), s, 1);
  const auto swept = static_cast<std::size_t>(s.bandwidth.joint);
  if (std::isnan(s.bandwidth.locked_rad[swept])) {
    bw.fail("angles_deg", fmt::format("expected the swept joint {} among the locked joints (by {} or {}), found it missing",
                                      s.plant.actuated[swept], s.plant.actuated[swept], models::without_side(s.plant.actuated[swept])));
  }
  s.bandwidth.amplitude_Nm = bw.number("amplitude_Nm", {0.01, 50.0});
  s.bandwidth.frequencies_Hz = bw.numbers("frequencies_Hz", {0.01, 0.25 / s.period_s}, 2, 64);
  s.bandwidth.min_cycles = bw.number("min_cycles", {2.0, 1000.0});
  s.bandwidth.min_duration_s = bw.number("min_duration_s", {0.1, 600.0});
  s.bandwidth.min_hybrid_band_at_joint_Hz = bw.number_or("min_hybrid_band_at_joint_Hz", 0.0, {0.0, 0.25 / s.period_s});
  bw.finish();
}

}  // namespace

ArmScenario::Goniometer::Movement read_goniometer_movement(config::Map& item, double lo_deg, double hi_deg) {
  ArmScenario::Goniometer::Movement m;
  m.name = item.string("name");
  m.from_rad = models::deg_to_rad(item.number("from_deg", {lo_deg, hi_deg}));
  m.to_rad = models::deg_to_rad(item.number("to_deg", {lo_deg, hi_deg}));
  m.move_s = item.number("move_s", {0.05, 60.0});
  m.pause_s = item.number("pause_s", {0.0, 60.0});
  m.repetitions = static_cast<int>(item.integer("repetitions", 1, 1000));
  m.tremor_amplitude_rad = models::deg_to_rad(item.number_or("tremor_amplitude_deg", 0.0, {0.0, 20.0}));
  m.tremor_frequency_Hz = item.number_or("tremor_frequency_Hz", 0.0, {0.0, 30.0});
  if ((m.tremor_amplitude_rad > 0) != (m.tremor_frequency_Hz > 0)) {
    item.fail("tremor_frequency_Hz", "a tremor needs both tremor_amplitude_deg and tremor_frequency_Hz above 0 (or neither)");
  }
  return m;
}

namespace {

/// `goniometer:` (E4): the driven joints, the held posture, the sensor, its filter, the feedback and
/// the movements.
void read_goniometer(config::Map gon, ArmScenario& s) {
  ArmScenario::Goniometer& g = s.goniometer;
  const std::vector<std::string>& io = s.plant.actuated;
  double lo = -180.0, hi = 180.0;  // the movements stay inside every driven joint's range, deg
  for (const std::string& name : gon.choices("joints", io, 1, io.size())) {
    const int j = torque_driven_joint(gon, "joints", name, s);
    g.joints.push_back(j);
    lo = std::max(lo, models::rad_to_deg(s.limits.joints[static_cast<std::size_t>(j)].min_angle_rad));
    hi = std::min(hi, models::rad_to_deg(s.limits.joints[static_cast<std::size_t>(j)].max_angle_rad));
  }
  g.held_rad = read_angles(gon.map("angles_deg"), s, 0);
  for (const int j : g.joints) {
    if (!std::isnan(g.held_rad[static_cast<std::size_t>(j)])) {
      gon.fail("angles_deg", fmt::format("expected the posture of the joints the goniometers do not drive, found {} (in joints: its "
                                         "angle is the person's)", io[static_cast<std::size_t>(j)]));
    }
  }
  if (lo > hi) gon.fail("joints", fmt::format("the driven joints' ranges do not overlap ([{}, {}] deg)", lo, hi));
  g.sample_rate_Hz = gon.number("sample_rate_Hz", {10.0, 1.0 / s.period_s});
  const double ratio = 1.0 / (g.sample_rate_Hz * s.period_s);
  if (std::abs(ratio - std::round(ratio)) > 1e-9) {
    gon.fail("sample_rate_Hz", fmt::format("must divide the control rate {} Hz, found {} Hz", 1.0 / s.period_s, g.sample_rate_Hz));
  }
  g.noise_rad = models::deg_to_rad(gon.number("noise_deg", {0.0, 10.0}));
  g.resolution_rad = models::deg_to_rad(gon.number("resolution_deg", {0.0, 5.0}));
  config::Map filter = gon.map("filter");
  g.filter_order = static_cast<int>(filter.integer("order", 1, control::kButterworthMaxOrder));
  g.cutoff_Hz = filter.number("cutoff_Hz", {0.1, 0.45 * g.sample_rate_Hz});
  filter.finish();
  g.settle_s = gon.number("settle_s", {1.5, 60.0});
  g.tail_s = gon.number("tail_s", {0.0, 60.0});
  g.max_delay_s = gon.number("max_delay_s", {0.01, 2.0});
  config::Map fb = gon.map("feedback");
  g.feedback_stiffness_Nm_per_rad = fb.number("stiffness_Nm_per_rad", {0.0, 1000.0});
  g.feedback_damping_Nms_per_rad = fb.number("damping_Nms_per_rad", {0.0, 100.0});
  fb.finish();
  config::Map sm = gon.map("smoothing");
  g.smoothing_order = static_cast<int>(sm.integer("order", 1, control::kButterworthMaxOrder));
  g.rate_cutoff_Hz = sm.number("rate_cutoff_Hz", {0.1, 0.45 * g.sample_rate_Hz});
  g.acceleration_jerk_density_rad2ps5 = sm.number("acceleration_jerk_density_rad2_per_s5", {1e-3, 1e9});
  g.command_cutoff_Hz = sm.number("command_cutoff_Hz", {0.1, 0.45 / s.period_s});
  sm.finish();
  g.encoder_velocity_cutoff_Hz = gon.number("encoder_velocity_cutoff_Hz", {1.0, 0.45 / s.period_s});
  g.pam_cutoff_Hz = gon.number("pam_cutoff_Hz", {0.01, 500.0});
  config::Map hold = gon.map("hold");
  g.hold_stiffness_Nm_per_rad = hold.number("stiffness_Nm_per_rad", {0.0, 1000.0});
  g.hold_damping_Nms_per_rad = hold.number("damping_Nms_per_rad", {0.0, 100.0});
  hold.finish();
  config::Map rejoin = gon.map("rejoin");
  g.rejoin_rate_radps = models::deg_to_rad(rejoin.number("rate_degps", {1.0, 180.0}));
  g.rejoin_lead_rad = models::deg_to_rad(rejoin.number("lead_deg", {0.1, 30.0}));
  rejoin.finish();
  if (gon.has("tremor")) {
    config::Map t = gon.map("tremor");
    control::TremorFilterParams& p = g.tremor.emplace();
    p.sample_rate_Hz = g.sample_rate_Hz;
    const double nyquist_Hz = 0.5 * g.sample_rate_Hz;
    p.min_frequency_Hz = t.number("min_frequency_Hz", {0.5, nyquist_Hz});
    p.max_frequency_Hz = t.number("max_frequency_Hz", {0.5, nyquist_Hz});
    p.initial_frequency_Hz = t.number("initial_frequency_Hz", {0.5, nyquist_Hz});
    p.highpass_Hz = t.number("highpass_Hz", {0.1, nyquist_Hz});
    p.amplitude_rate = t.number("amplitude_rate", {1e-6, 0.5});
    p.frequency_rate = t.number("frequency_rate", {1e-6, 0.5});
    p.tracking_rate = t.number("tracking_rate", {1e-6, 0.5});
    p.gate_on_rad = models::deg_to_rad(t.number("gate_on_deg", {0.0, 30.0}));
    p.gate_full_rad = models::deg_to_rad(t.number("gate_full_deg", {0.0, 30.0}));
    if (const control::TremorFilterProblem problem = control::find_tremor_filter_problem(p); problem.field) {
      const std::string_view field = problem.field;  // the gates are read in degrees here
      t.fail(field == "gate_full_rad" ? "gate_full_deg" : field, problem.expected);
    }
    t.finish();
  }
  config::Map th = gon.map("thresholds");
  g.max_held_excursion_deg = th.number("max_held_excursion_deg", {0.0, 180.0});
  g.max_passive_speed_degps = th.number("max_passive_speed_degps", {0.0, 5000.0});
  g.command_hf_above_Hz = th.number("command_hf_above_Hz", {0.1, 0.45 / s.period_s});
  g.max_command_hf_rms_Nm = th.number("max_command_hf_rms_Nm", {0.0, 100.0});
  g.max_command_delay_s = th.number("max_command_delay_ms", {0.0, 1000.0}) * 1e-3;
  th.finish();
  for (config::Map item : gon.maps("movements", 1, 16)) {
    g.movements.push_back(read_goniometer_movement(item, lo, hi));
    item.finish();
  }
  gon.finish();
}

/// `identification:` (peha identify-gravity): the postures, the sweeps and the fit's checks.
void read_identification(config::Map id, ArmScenario& s) {
  ArmScenario::Identification& d = s.identification.emplace();
  d.sweep_rad = models::deg_to_rad(id.number("sweep_deg", {1.0, 30.0}));
  d.sweep_speed_radps = models::deg_to_rad(id.number("sweep_speed_deg_per_s", {0.5, 90.0}));
  d.ramp_s = id.number("ramp_s", {0.05, 10.0});
  d.window_rad = models::deg_to_rad(id.number("window_deg", {0.1, models::rad_to_deg(d.sweep_rad)}));
  d.move_s = id.number("move_s", {0.2, 60.0});
  d.settle_s = id.number("settle_s", {0.0, 60.0});
  d.min_speed_fraction = id.number("min_speed_fraction", {0.0, 1.0});
  d.friction_learning_gain = id.number("friction_learning_gain", {0.0, 1.0});
  d.pam_cutoff_Hz = id.number("pam_cutoff_Hz", {0.01, 500.0});
  // The cruise must reach the window: the reference passes the posture at the sweep's middle, at full
  // speed only when the ramps end before the window starts.
  if (d.sweep_rad - d.window_rad < 0.5 * d.sweep_speed_radps * d.ramp_s) {
    id.fail("window_deg", fmt::format("the reference is still speeding up inside the window: sweep_deg - window_deg = {:.2f} deg must be at "
                                      "least half a ramp at cruise speed ({:.2f} deg); widen the sweep, narrow the window or shorten ramp_s",
                                      models::rad_to_deg(d.sweep_rad - d.window_rad), models::rad_to_deg(0.5 * d.sweep_speed_radps * d.ramp_s)));
  }
  // The swept joints: those whose actuator follows a torque (PEHA, PAM pair).
  for (std::size_t i = 0; i < s.controller.joints.size(); ++i) {
    if (s.controller.joints[i].mode != control::ArmJointMode::kHoldPressure) d.joints.push_back(i);
  }
  // The rig's PD per swept joint, by arm joint (every side) or io joint (one side).
  auto per_swept_joint = [&](const char* key, const config::Range& range) {
    config::Map m = id.map(key);
    const std::vector<double> v = read_joint_map(m, s, [&](std::size_t) { return range; });
    std::vector<double> out;
    for (const std::size_t i : d.joints) {
      if (std::isnan(v[i])) m.fail(s.plant.actuated[i], fmt::format("the rig sweeps {}: give its value", s.plant.actuated[i]));
      out.push_back(v[i]);
    }
    return out;
  };
  d.stiffness_Nm_per_rad = per_swept_joint("stiffness_Nm_per_rad", {0.0, 1e4});
  d.damping_Nms_per_rad = per_swept_joint("damping_Nms_per_rad", {0.0, 1e3});
  d.max_residual_rms_Nm = id.number("max_residual_rms_Nm", {0.001, 100.0});
  d.max_change_fraction = id.number("max_change_fraction", {0.001, 10.0});
  d.rank_tolerance = id.number_or("rank_tolerance", d.rank_tolerance, {1e-12, 1.0});
  for (config::Map item : id.maps("postures", 3, 64)) {
    ArmPosture a;
    a.name = item.string("name");
    config::Map angles = item.map("angles_deg");
    a.target_rad = read_angles(angles, s, 1);
    // Every swept joint has an angle, its whole sweep inside the joint's range (a stop would hold part
    // of the torque); the others (a constant-pressure wrist) are not named.
    for (std::size_t i = 0; i < a.target_rad.size(); ++i) {
      const safety::JointLimits& lim = s.limits.joints[i];
      const bool is_swept = std::find(d.joints.begin(), d.joints.end(), i) != d.joints.end();
      const std::string& io_name = s.plant.actuated[i];
      if (!is_swept) {
        if (!std::isnan(a.target_rad[i])) {
          item.fail("angles_deg", fmt::format("names {}, which the rig does not sweep (a constant-pressure hold): remove it", io_name));
        }
        continue;
      }
      if (std::isnan(a.target_rad[i])) item.fail("angles_deg", fmt::format("names no angle for {}; the rig sweeps every PEHA and PAM-pair joint", io_name));
      const double lo = lim.min_angle_rad + d.sweep_rad + models::kRadPerDeg, hi = lim.max_angle_rad - d.sweep_rad - models::kRadPerDeg;
      if (a.target_rad[i] < lo || a.target_rad[i] > hi) {
        item.fail("angles_deg", fmt::format("{} at {:.1f} deg: its sweep of +-{:.1f} deg must stay 1 deg inside the joint's range, so the "
                                            "posture must lie in [{:.1f}, {:.1f}] deg",
                                            io_name, models::rad_to_deg(a.target_rad[i]), models::rad_to_deg(d.sweep_rad),
                                            models::rad_to_deg(lo), models::rad_to_deg(hi)));
      }
    }
    item.finish();
    d.postures.push_back(a);
  }
  id.finish();
}

}  // namespace

void use_gravity_identification(ArmScenario& scenario, const std::filesystem::path& path) {
  scenario.controller.arm = calibration::read_gravity_identification(config::Document::load_file(path), scenario.nominal_arm);
  scenario.gravity_identification_file = path;
}

ArmScenario read_arm_scenario(const config::Document& doc) {
  config::Map root = doc.root();
  ArmScenario s;
  const ScenarioHeader header = read_scenario_header(root, "arm");
  s.description = header.description;
  s.seed = header.seed;
  const models::BodyConfig body = models::read_body(config::Document::load_file(root.path_value("body")));

  config::Map run = root.map("run");
  s.period_s = run.number("control_period_s", {1e-4, 0.1});
  run.finish();
  config::Map limits = root.map("limits");
  ArmLimits l;
  l.supply_Pa = limits.number("supply_pressure_MPa", {0.1, 1.0}) * 1e6;
  l.rate_Pa_per_s = limits.number("pressure_rate_MPa_per_s", {0.01, 100.0}) * 1e6;
  l.motor_rate_Nm_per_s = limits.number("motor_rate_Nm_per_s", {0.1, 1e5});
  limits.finish();

  read_arm_controller(root.map("controller"), body, l, s);
  config::Map plant = root.map("plant");
  read_arm_plant(plant, root.map("operator"), body, l, s);
  read_postures(root.map("postures"), s);
  s.faults = sim::read_plant_faults(root, s.plant.actuated, postures_duration_s(s));
  if (root.has("bandwidth")) read_bandwidth(root.map("bandwidth"), s);  // E6's section (optional)
  if (root.has("mfb")) s.link = mfb::read_link_config(root.map("mfb"), s.plant.actuated);  // one board or several: each io joint on one
  if (root.has("goniometer")) read_goniometer(root.map("goniometer"), s);  // E4's section (optional)
  if (root.has("identification")) read_identification(root.map("identification"), s);
  s.verdict = safety::read_verdict_thresholds(root);
  for (std::size_t i = 0; i < s.controller.joints.size(); ++i) {
    // A constant-pressure hold (the wrist) has no pretension control: its wires are checked for slack.
    if (s.controller.joints[i].mode == control::ArmJointMode::kHoldPressure) s.verdict.slack_check_only_joints |= 1u << i;
  }
  // The supervisor's plausibility stage (docs/safety.md), on unless the scenario says otherwise. A
  // constant-pressure hold keeps no pretension by design: its wires are not held to the tension floor.
  safety::read_monitor_params(root, s.limits.monitor);
  s.lifecycle = runtime::read_lifecycle(root);
  s.telemetry = runtime::read_telemetry(root);
  for (std::size_t i = 0; i < s.controller.joints.size(); ++i) {
    if (s.controller.joints[i].mode == control::ArmJointMode::kHoldPressure) {
      s.limits.monitor.tension_checked[i] = false;
      s.limits.monitor.governed[i] = false;  // descend keeps its constant pressures
    }
  }
  root.finish();
  if (!s.gravity_identification_file.empty()) use_gravity_identification(s, s.gravity_identification_file);
  return s;
}

const std::vector<std::string>& arm_joint_names(const ArmScenario& scenario) { return scenario.plant.actuated; }

void add_arm_envelope_checks(const ArmScenario& scenario, const safety::JointModels& joints,
                             const safety::Envelope& envelope, safety::Verdict& verdict) {
  verdict.thresholds = scenario.verdict;
  safety::add_envelope_checks(scenario.limits, joints, arm_joint_names(scenario), envelope, scenario.verdict, verdict);
}

safety::JointSample arm_joint_sample(const io::SensorState& state, const io::Command& sent, const sim::ArmTruth* truth,
                                     std::size_t joint) noexcept {
  safety::JointSample j;
  if (truth) {
    const sim::PehaJointTruth& t = truth->actuators[joint];
    j = {{t.muscle_force_N[0], t.muscle_force_N[1]}, std::min(t.pulley_tension_min_N[0], t.pulley_tension_min_N[1]),
         {t.pressure_Pa[0], t.pressure_Pa[1]}, t.motor_torque_Nm, truth->actuated_q_rad[joint]};
  } else {
    const io::JointSensors& s = state.joints[joint];
    j = {{s.agonist_loadcell_N, s.antagonist_loadcell_N}, std::min(s.agonist_loadcell_N, s.antagonist_loadcell_N),
         {s.agonist_pressure_Pa, s.antagonist_pressure_Pa}, sent.joints[joint].motor_torque_Nm, s.angle_rad};
  }
  return j;
}

safety::JointModels arm_joint_models(const control::ArmControllerModel& model) noexcept {
  safety::JointModels joints{};
  for (std::size_t i = 0; i < model.joints.size() && i < joints.size(); ++i) joints[i] = &model.joints[i].actuator;
  return joints;
}

}  // namespace peha::experiments
