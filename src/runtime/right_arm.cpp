#include "peha/runtime/right_arm.hpp"

#include "peha/models/anthropometry.hpp"
#include "peha/control/butterworth.hpp"
#include "peha/models/model_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <complex>
#include <cmath>
#include <limits>
#include <numbers>

namespace peha::runtime {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr const char* kJointKeys[3] = {"shoulder", "elbow", "wrist"};
constexpr const char* kJointNames[3] = {"R_SFE", "R_EFE", "R_WFE"};

}  // namespace

ArmScenario read_arm_scenario(const config::Document& doc) {
  config::Map root = doc.root();
  ArmScenario s;
  root.choice("experiment", {"right_arm"});
  s.description = root.string("description");
  s.seed = static_cast<std::uint64_t>(root.integer("seed", 0, 1L << 40));
  const models::RightArmConfig body = models::read_right_arm(config::Document::load_file(root.path_value("body")));

  config::Map run = root.map("run");
  s.period_s = run.number("control_period_s", {1e-4, 0.1});
  run.finish();
  config::Map limits = root.map("limits");
  const double supply_Pa = limits.number("supply_pressure_MPa", {0.1, 1.0}) * 1e6;
  const double rate_Pa = limits.number("pressure_rate_MPa_per_s", {0.01, 100.0}) * 1e6;
  const double motor_rate = limits.number("motor_rate_Nm_per_s", {0.1, 1e5});
  limits.finish();

  config::Map ctl = root.map("controller");
  s.controller.arm = body.controller.model();
  s.controller.velocity_cutoff_Hz = ctl.number("velocity_cutoff_Hz", {0.1, 500.0});
  s.controller.allocation = control::read_allocation(ctl.map("allocation"), supply_Pa);
  s.limits.joint_count = 3;
  s.limits.period_s = s.period_s;
  for (int i = 0; i < 3; ++i) {
    config::Map j = ctl.map(kJointKeys[i]);
    control::ArmActuatedJoint joint;
    joint.model_joint = i;  // SFE, EFE, WFE are the first three joints of the arm model
    const double lo = j.number("min_angle_deg", {-180.0, 180.0}) * kDeg;
    const double hi = j.number("max_angle_deg", {lo / kDeg, 180.0}) * kDeg;
    if (i == 2) {
      joint.mode = control::ArmJointMode::kHoldPressure;
      joint.hold_pressure_Pa = j.number("hold_pressure_MPa", {0.0, supply_Pa * 1e-6}) * 1e6;
    }
    joint.actuator = models::read_joint_model(j, kJointNames[i], supply_Pa);
    j.finish();
    safety::JointLimits& lim = s.limits.joints[static_cast<std::size_t>(i)];
    lim.model = joint.actuator;
    lim.supply_pressure_Pa = supply_Pa;
    lim.pretension_N = s.controller.allocation.pretension_N;
    lim.pressure_rate_Pa_per_s = rate_Pa;
    lim.motor_rate_Nm_per_s = motor_rate;
    lim.min_angle_rad = lo;
    lim.max_angle_rad = hi;
    s.controller.joints.push_back(joint);
  }
  ctl.finish();

  config::Map plant = root.map("plant");
  sim::RightArmPlantParams& p = s.plant;
  p.model = body.plant.model();
  p.mjcf = sim::right_arm_mjcf_options();
  p.timestep_s = sim::read_timestep_s(plant, s.period_s);
  p.mjcf.timestep_s = p.timestep_s;
  p.control_period_s = s.period_s;
  p.encoder_counts_per_rev = plant.number("encoder_counts_per_rev", {16, 1e9});
  config::Map pressure = plant.map("pressure_sensor");
  p.pressure_noise_Pa = pressure.number("noise_MPa", {0.0, 0.1}) * 1e6;
  p.pressure_range_Pa = pressure.number("range_MPa", {0.1, 2.0}) * 1e6;
  pressure.finish();
  const std::vector<double> q0 = plant.numbers("initial_angles_deg", {-180.0, 180.0}, 5, 5);
  for (double a : q0) p.initial_q_rad.push_back(a * kDeg);
  for (int i = 0; i < 3; ++i) {
    config::Map j = plant.map(kJointKeys[i]);
    p.actuated.emplace_back(kJointNames[i]);
    p.actuators.push_back(sim::read_peha_joint_plant(j, supply_Pa, /*has_motor=*/i < 2));
    j.finish();
  }
  plant.finish();
  p.seed = s.seed;

  config::Map op = root.map("operator");
  p.operator_hands.stiffness_Nm_per_rad = op.number("stiffness_Nm_per_rad", {0.0, 1e4});
  p.operator_hands.damping_Nms_per_rad = op.number("damping_Nms_per_rad", {0.0, 1e3});
  p.operator_hands.max_torque_Nm = op.number("max_torque_Nm", {0.0, 200.0});
  op.finish();

  config::Map postures = root.map("postures");
  s.move_s = postures.number("move_s", {0.1, 60.0});
  s.hold_s = postures.number("hold_s", {0.0, 60.0});
  s.observe_s = postures.number("observe_s", {0.1, 600.0});
  for (config::Map item : postures.maps("list", 1, 32)) {
    ArmPosture a;
    a.name = item.string("name");
    a.sfe_rad = item.number("sfe_deg", {s.limits.joints[0].min_angle_rad / kDeg, s.limits.joints[0].max_angle_rad / kDeg}) * kDeg;
    a.efe_rad = item.number("efe_deg", {s.limits.joints[1].min_angle_rad / kDeg, s.limits.joints[1].max_angle_rad / kDeg}) * kDeg;
    item.finish();
    s.postures.push_back(a);
  }
  postures.finish();
  config::Map bw = root.map("bandwidth");
  const std::string joint = bw.choice("joint", {"shoulder", "elbow"});
  s.bandwidth.joint = joint == "shoulder" ? 0 : 1;
  s.bandwidth.sfe_rad = bw.number("sfe_deg", {-100.0, 60.0}) * kDeg;
  s.bandwidth.efe_rad = bw.number("efe_deg", {0.0, 135.0}) * kDeg;
  s.bandwidth.amplitude_Nm = bw.number("amplitude_Nm", {0.01, 50.0});
  s.bandwidth.frequencies_Hz = bw.numbers("frequencies_Hz", {0.01, 0.25 / s.period_s}, 2, 64);
  s.bandwidth.min_cycles = bw.number("min_cycles", {2.0, 1000.0});
  s.bandwidth.min_duration_s = bw.number("min_duration_s", {0.1, 600.0});
  bw.finish();
  if (root.has("mfb")) s.link = read_link_config(root.map("mfb"));
  config::Map gon = root.map("goniometer");
  ArmScenario::Goniometer& g = s.goniometer;
  const double elbow_lo = s.limits.joints[1].min_angle_rad / kDeg, elbow_hi = s.limits.joints[1].max_angle_rad / kDeg;
  g.sfe_rad = gon.number("sfe_deg", {s.limits.joints[0].min_angle_rad / kDeg, s.limits.joints[0].max_angle_rad / kDeg}) * kDeg;
  g.sample_rate_Hz = gon.number("sample_rate_Hz", {10.0, 1.0 / s.period_s});
  const double ratio = 1.0 / (g.sample_rate_Hz * s.period_s);
  if (std::abs(ratio - std::round(ratio)) > 1e-9) {
    gon.fail("sample_rate_Hz", fmt::format("must divide the control rate {} Hz, found {} Hz", 1.0 / s.period_s, g.sample_rate_Hz));
  }
  g.noise_rad = gon.number("noise_deg", {0.0, 10.0}) * kDeg;
  g.resolution_rad = gon.number("resolution_deg", {0.0, 5.0}) * kDeg;
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
  for (config::Map item : gon.maps("movements", 1, 16)) {
    ArmScenario::Goniometer::Movement m;
    m.name = item.string("name");
    m.from_rad = item.number("from_deg", {elbow_lo, elbow_hi}) * kDeg;
    m.to_rad = item.number("to_deg", {elbow_lo, elbow_hi}) * kDeg;
    m.move_s = item.number("move_s", {0.05, 60.0});
    m.pause_s = item.number("pause_s", {0.0, 60.0});
    m.repetitions = static_cast<int>(item.integer("repetitions", 1, 1000));
    item.finish();
    g.movements.push_back(m);
  }
  gon.finish();
  root.finish();
  return s;
}

BandwidthResult run_bandwidth(const ArmScenario& scenario, bool hybrid) {
  const ArmScenario::Bandwidth& b = scenario.bandwidth;
  sim::RightArmPlantParams plant_params = scenario.plant;
  plant_params.initial_q_rad[0] = b.sfe_rad;
  plant_params.initial_q_rad[1] = b.efe_rad;
  // A torque bench: shoulder and elbow locked (equality constraints), so the delivered torque is the
  // actuator's, not a motion's.
  plant_params.mjcf.joints[0].locked = plant_params.mjcf.joints[1].locked = true;
  plant_params.mjcf.joints[0].locked_at_rad = b.sfe_rad;
  plant_params.mjcf.joints[1].locked_at_rad = b.efe_rad;
  sim::RightArmBackend plant(plant_params);
  control::ArmControllerModel model = scenario.controller;
  model.allocation.use_motor = hybrid;
  // PAM-only: no motor to hand the fast part to, so no low-pass split either.
  if (!hybrid) model.allocation.pam_cutoff_Hz = 0.25 / scenario.period_s;
  control::ArmController controller(model);
  controller.set_mode(b.joint, control::ArmJointMode::kCommanded);
  safety::LimitsData limits;
  const double r0 = plant_params.actuators[static_cast<std::size_t>(b.joint)].pulley_radius_m;

  BandwidthResult r;
  r.variant = hybrid ? "hybrid" : "pam_only";
  r.min_wire_tension_N = std::numeric_limits<double>::infinity();
  io::SensorState state;
  io::Command command;
  auto step = [&](double desired_Nm) {
    plant.read(state);
    controller.set_desired_torque(b.joint, desired_Nm);
    controller.update(state, command);
    safety::apply_limits(scenario.limits, limits, state, command);
    plant.write(command);
    const sim::PehaJointTruth& j = plant.truth().actuators[static_cast<std::size_t>(b.joint)];
    r.peak_muscle_force_N = std::max({r.peak_muscle_force_N, j.muscle_force_N[0], j.muscle_force_N[1]});
    r.min_wire_tension_N = std::min({r.min_wire_tension_N, j.pulley_tension_min_N[0], j.pulley_tension_min_N[1]});
    r.peak_motor_torque_Nm = std::max(r.peak_motor_torque_Nm, std::abs(j.motor_torque_Nm));
    return r0 * (j.muscle_force_N[0] - j.muscle_force_N[1]) + j.motor_torque_Nm;  // delivered, Nm
  };
  // The bias: the controller's gravity torque at the locked posture, settled for 2 s.
  double bias = 0.0;
  for (int k = 0; k < static_cast<int>(2.0 / scenario.period_s); ++k) {
    controller.set_mode(b.joint, control::ArmJointMode::kGravity);
    step(0.0);
    bias = controller.diagnostics()[static_cast<std::size_t>(b.joint)].torque_gravity_Nm;
  }
  controller.set_mode(b.joint, control::ArmJointMode::kCommanded);
  for (double f : b.frequencies_Hz) {
    const double cycles = std::ceil(std::max(b.min_cycles, b.min_duration_s * f));
    const auto n_cycle = static_cast<long>(std::llround(1.0 / (f * scenario.period_s)));
    const long total = static_cast<long>(cycles) * n_cycle;
    std::complex<double> U = 0, Y = 0;
    for (long k = 0; k < total; ++k) {
      const double phase = 2.0 * std::numbers::pi * f * k * scenario.period_s;
      const double u = b.amplitude_Nm * std::sin(phase);
      const double y = step(bias + u) - bias;
      if (k >= n_cycle) {  // skip the first cycle (transient); whole cycles remain
        const std::complex<double> e = std::polar(1.0, -phase);
        U += u * e;
        Y += y * e;
      }
    }
    const std::complex<double> H = Y / U;
    r.bode.push_back({f, std::abs(H), std::arg(H) * 180.0 / std::numbers::pi});
  }
  const double threshold = 1.0 / std::sqrt(2.0);
  r.bandwidth_3dB_Hz = r.bode.back().frequency_Hz;
  for (std::size_t i = 1; i < r.bode.size(); ++i) {
    if (r.bode[i].gain < threshold && r.bode[i - 1].gain >= threshold) {
      const double l0 = std::log(r.bode[i - 1].frequency_Hz), l1 = std::log(r.bode[i].frequency_Hz);
      const double w = (r.bode[i - 1].gain - threshold) / (r.bode[i - 1].gain - r.bode[i].gain);
      r.bandwidth_3dB_Hz = std::exp(l0 + w * (l1 - l0));
      r.reached_3dB = true;
      break;
    }
  }
  return r;
}

const std::vector<std::string>& arm_log_columns() {
  static const std::vector<std::string> columns = [] {
    std::vector<std::string> c = {"t_s", "operator_active"};
    for (const char* j : {"sfe", "efe", "wfe"}) {
      for (const char* f : {"angle_rad", "plant_angle_rad", "tau_gravity_Nm", "tau_desired_Nm", "tau_motor_cmd_Nm",
                            "operator_torque_Nm", "p_agonist_cmd_MPa", "p_antagonist_cmd_MPa", "f_agonist_loadcell_N",
                            "f_antagonist_loadcell_N", "plant_force_agonist_N", "plant_force_antagonist_N"}) {
        c.push_back(fmt::format("{}_{}", j, f));
      }
    }
    return c;
  }();
  return columns;
}

sim::RightArmPlantParams postures_plant_params(const ArmScenario& scenario) {
  // The operator's script: hold the arm where it starts while compensation comes on, then for each
  // posture carry the arm there, hold, let go, and watch.
  sim::RightArmPlantParams p = scenario.plant;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p.operator_hands.moves.push_back({"start", 0.0, 2.0, 2.0, {p.initial_q_rad[0], p.initial_q_rad[1], nan}});
  double t = 2.0 + scenario.observe_s * 0.2;
  for (const ArmPosture& a : scenario.postures) {
    p.operator_hands.moves.push_back({a.name, t, scenario.move_s + scenario.hold_s, scenario.move_s, {a.sfe_rad, a.efe_rad, nan}});
    t += scenario.move_s + scenario.hold_s + scenario.observe_s;
  }
  return p;
}

std::vector<double> postures_release_times_s(const ArmScenario& scenario) {
  // The operator lets go at the end of each posture's move (the script's moves after "start").
  const sim::RightArmPlantParams script = postures_plant_params(scenario);
  const std::vector<sim::OperatorMove>& moves = script.operator_hands.moves;
  std::vector<double> release_s;
  for (std::size_t i = 1; i < moves.size(); ++i) release_s.push_back(moves[i].start_s + moves[i].duration_s);
  return release_s;
}

double postures_duration_s(const ArmScenario& scenario) { return postures_release_times_s(scenario).back() + scenario.observe_s; }

ArmJointSample arm_joint_sample(const io::SensorState& state, const io::Command& command, const sim::RightArmTruth* truth,
                                std::size_t joint) noexcept {
  ArmJointSample j;
  if (truth) {
    const sim::PehaJointTruth& t = truth->actuators[joint];
    j = {{t.muscle_force_N[0], t.muscle_force_N[1]}, std::min(t.pulley_tension_min_N[0], t.pulley_tension_min_N[1]),
         {t.pressure_Pa[0], t.pressure_Pa[1]}, t.motor_torque_Nm};
  } else {
    const io::JointSensors& s = state.joints[joint];
    j = {{s.agonist_force_N, s.antagonist_force_N}, std::min(s.agonist_force_N, s.antagonist_force_N),
         {s.agonist_pressure_Pa, s.antagonist_pressure_Pa}, command.joints[joint].motor_torque_Nm};
  }
  return j;
}

bool arm_joint_within_limits(const ArmScenario& scenario, std::size_t joint, const ArmJointSample& j) noexcept {
  const models::JointModel& jm = scenario.controller.joints[joint].actuator;
  const double supply_Pa = scenario.limits.joints[joint].supply_pressure_Pa;
  return j.muscle_force_N[0] <= models::force_ceiling_N(jm.agonist) && j.muscle_force_N[1] <= models::force_ceiling_N(jm.antagonist) &&
         j.pressure_Pa[0] <= supply_Pa && j.pressure_Pa[1] <= supply_Pa && std::abs(j.motor_torque_Nm) <= jm.motor_max_torque_Nm + 1e-12;
}

PosturesResult run_postures(const ArmScenario& scenario, RowSink* log) {
  sim::RightArmBackend plant(postures_plant_params(scenario));
  return run_postures_on(scenario, plant, &plant, log);
}

PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, const sim::RightArmBackend* sim, RowSink* log,
                               const CycleHooks& hooks) {
  const std::vector<double> release_s = postures_release_times_s(scenario);
  const double duration_s = postures_duration_s(scenario);
  const sim::RightArmPlantParams script = postures_plant_params(scenario);  // where the operator's hands are, by the clock
  control::ArmController controller(scenario.controller);
  safety::LimitsData limits_data;
  const double nan = std::numeric_limits<double>::quiet_NaN();

  PosturesResult r;
  r.min_wire_tension_N = std::numeric_limits<double>::infinity();
  bool safe = true;
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  std::vector<double> sfe(steps + 1), efe(steps + 1);
  io::SensorState state;
  io::Command command;
  std::vector<double> row(arm_log_columns().size());
  const auto wall_start = std::chrono::steady_clock::now();
  auto hold = [&](std::size_t k) {  // no new sample: the command is held
    sfe[k] = k ? sfe[k - 1] : 0.0;
    efe[k] = k ? efe[k - 1] : 0.0;
  };
  auto step = [&](std::size_t k) -> std::uint32_t {
    controller.update(state, command);
    const std::uint32_t flags = safety::apply_limits(scenario.limits, limits_data, state, command);
    const sim::RightArmTruth* truth = sim ? &sim->truth() : nullptr;
    bool operator_active = false;
    if (truth) {
      operator_active = truth->operator_active;
    } else {
      for (const auto& m : script.operator_hands.moves) operator_active |= state.time_s >= m.start_s && state.time_s < m.start_s + m.duration_s;
    }
    sfe[k] = truth ? truth->q_rad[0] : state.joints[0].angle_rad;
    efe[k] = truth ? truth->q_rad[1] : state.joints[1].angle_rad;
    for (std::size_t a = 0; a < static_cast<std::size_t>(state.joint_count); ++a) {
      const ArmJointSample j = arm_joint_sample(state, command, truth, a);
      r.peak_muscle_force_N = std::max({r.peak_muscle_force_N, j.muscle_force_N[0], j.muscle_force_N[1]});
      r.min_wire_tension_N = std::min(r.min_wire_tension_N, j.min_tension_N);
      if (truth) r.peak_operator_torque_Nm = std::max(r.peak_operator_torque_Nm, std::abs(truth->operator_torque_Nm[a]));
      safe = safe && arm_joint_within_limits(scenario, a, j);
    }
    if (log) {
      std::size_t col = 0;
      row[col++] = state.time_s;
      row[col++] = operator_active ? 1.0 : 0.0;
      const auto& diag = controller.diagnostics();
      for (std::size_t a = 0; a < 3; ++a) {
        const sim::PehaJointTruth* j = truth ? &truth->actuators[a] : nullptr;
        const double values[] = {state.joints[a].angle_rad, truth ? truth->q_rad[a] : nan, diag[a].torque_gravity_Nm, diag[a].torque_desired_Nm,
                                 command.joints[a].motor_torque_Nm, truth ? truth->operator_torque_Nm[a] : nan,
                                 command.joints[a].agonist_pressure_Pa * 1e-6, command.joints[a].antagonist_pressure_Pa * 1e-6,
                                 state.joints[a].agonist_force_N, state.joints[a].antagonist_force_N, j ? j->muscle_force_N[0] : nan,
                                 j ? j->muscle_force_N[1] : nan};
        for (double v : values) row[col++] = v;
      }
      log->push_row(row);
    }
    return flags;
  };
  const std::size_t done = run_cycles(backend, hooks, steps, state, command, step, hold);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.realtime_factor = duration_s / std::max(wall_s, 1e-9);
  r.within_limits = safe && r.min_wire_tension_N > 0.0;

  const auto window = static_cast<std::size_t>(std::llround(scenario.observe_s / scenario.period_s));
  for (std::size_t i = 0; i < scenario.postures.size(); ++i) {
    PostureResult p;
    p.name = scenario.postures[i].name;
    p.target_deg[0] = scenario.postures[i].sfe_rad / kDeg;
    p.target_deg[1] = scenario.postures[i].efe_rad / kDeg;
    const auto k0 = static_cast<std::size_t>(std::llround(release_s[i] / scenario.period_s));
    if (k0 > done) continue;  // a run ended early analyses what it has
    const std::size_t k1 = std::min(k0 + window, done);
    const std::vector<double>* angles[2] = {&sfe, &efe};
    for (int j = 0; j < 2; ++j) {
      const std::vector<double>& a = *angles[j];
      p.released_deg[j] = a[k0] / kDeg;
      p.drift_deg[j] = (a[k1] - a[k0]) / kDeg;
      for (std::size_t k = k0; k <= k1; ++k) p.max_excursion_deg[j] = std::max(p.max_excursion_deg[j], std::abs(a[k] - a[k0]) / kDeg);
    }
    r.postures.push_back(p);
  }
  return r;
}

}  // namespace peha::runtime
