#include "peha/experiments/arm_identification/arm_identification.hpp"

#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/hardware/replay_backend.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>

namespace peha::experiments {
namespace {

constexpr double kStartHold_s = 2.0;  // the operator holds the start posture while compensation comes on (as E3)

/// One leg of the rig's reference: a move to `target` (one angle per swept joint) over move_s (minimum
/// jerk, or for a sweep a cruise at constant speed between two ramps), then a hold of hold_s. A sweep
/// measures posture `posture` (-1: none, a warm-up) in direction `side` (0 up, 1 down) while the leg's
/// clock is in [window_from_s, window_to_s].
struct Leg {
  std::vector<double> target_rad;
  double move_s = 1, hold_s = 0;
  bool sweep = false;
  int posture = -1, side = -1;
  double window_from_s = 0, window_to_s = 0;
};

/// `posture`'s angle of each swept joint plus `offset_rad`.
std::vector<double> swept_targets(const ArmScenario::Identification& id, const ArmPosture& posture, double offset_rad) {
  std::vector<double> q;
  for (const std::size_t i : id.joints) q.push_back(posture.target_rad[i] + offset_rad);
  return q;
}

std::vector<Leg> legs_of(const ArmScenario::Identification& id) {
  std::vector<Leg> legs;
  const double sweep_s = 2 * id.sweep_rad / id.sweep_speed_radps + id.ramp_s;  // cruise + one ramp's worth of distance lost to two
  const double half_window_s = id.window_rad / id.sweep_speed_radps;
  for (std::size_t p = 0; p < id.postures.size(); ++p) {
    const ArmPosture& a = id.postures[p];
    legs.push_back({swept_targets(id, a, -id.sweep_rad), id.move_s, id.settle_s});
    // The first posture is swept once more before it is measured: the rig learns the friction it
    // must push against (below) on that pair.
    for (int pass = p == 0 ? 0 : 1; pass < 2; ++pass) {
      for (int side = 0; side < 2; ++side) {
        const double to = side == 0 ? id.sweep_rad : -id.sweep_rad;  // up, then back down
        legs.push_back({swept_targets(id, a, to), sweep_s, id.settle_s, true, pass == 1 ? static_cast<int>(p) : -1, side,
                        0.5 * sweep_s - half_window_s, 0.5 * sweep_s + half_window_s});
      }
    }
  }
  return legs;
}

double min_jerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
}

/// Fraction of a sweep done at `t_s` of `total_s`: the speed rises as a half cosine over ramp_s,
/// cruises, and falls the same way; the middle is passed at total_s / 2 at cruise speed.
double cruise(double t_s, double total_s, double ramp_s) {
  if (t_s <= 0) return 0;
  if (t_s >= total_s) return 1;
  const double v = 1.0 / (total_s - ramp_s);
  auto ramp = [&](double t) { return v * (0.5 * t - ramp_s / (2 * std::numbers::pi) * std::sin(std::numbers::pi * t / ramp_s)); };
  if (t_s < ramp_s) return ramp(t_s);
  if (t_s > total_s - ramp_s) return 1.0 - ramp(total_s - t_s);
  return v * (0.5 * ramp_s + (t_s - ramp_s));
}

/// The capstan ratio k >= 0 for which the upward and the downward sweep give the same pulley-side
/// torque: up a/k - b k + m_up = down a' k - b'/k + m_down (a, b: r0 x agonist, antagonist force), i.e.
/// (b + a') k^2 + (m_down - m_up) k - (a + b') = 0. 1 (no friction) when the wires carry nothing.
double capstan_ratio(double a_up, double b_up, double m_up, double a_down, double b_down, double m_down) {
  const double qa = b_up + a_down, qb = m_down - m_up, qc = -(a_up + b_down);
  if (!(qa > 1e-9)) return 1.0;
  return (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
}

}  // namespace

sim::ArmPlantParams identification_plant_params(const ArmScenario& scenario, const sim::ArmPlantParams& plant) {
  sim::ArmPlantParams p = plant;
  p.operator_hands.moves.clear();
  // The operator holds every swept joint where the arm starts while compensation comes on; the
  // others (a constant-pressure wrist) stay free.
  std::vector<double> hold(scenario.controller.joints.size(), std::numeric_limits<double>::quiet_NaN());
  if (scenario.identification) {
    for (const std::size_t i : scenario.identification->joints) {
      hold[i] = p.initial_q_rad[static_cast<std::size_t>(scenario.controller.joints[i].model_joint)];
    }
  }
  p.operator_hands.moves.push_back({"start", 0.0, kStartHold_s, kStartHold_s, hold});
  return p;
}

ArmIdentificationResult identify_arm_gravity(const ArmScenario& given, const sim::ArmPlantParams& plant_params,
                                             const std::function<void(const std::string&)>& progress) {
  const ArmScenario scenario = identification_scenario(given);
  const hardware::Hardware plant = hardware::open_backend(hardware::BackendUri{}, arm_hardware(scenario, identification_plant_params(scenario, plant_params)));
  IdentificationRecording recording = record_identification(scenario, *plant.backend, progress);
  return fit_identification(scenario, recording);
}

ArmScenario identification_scenario(const ArmScenario& given) {
  // Always from the body file's prior, whatever identification the scenario's controller already
  // uses: the rig's gravity compensation and the fit's prior do not depend on an earlier result (a
  // rerun on the shipped config reproduces the shipped file, and the robustness matrix identifies
  // each variant as a new rig would).
  ArmScenario scenario = given;
  scenario.controller.arm = scenario.nominal_arm;
  if (!scenario.identification) throw config::Error("the arm scenario has no identification: section (docs/identification.md)");
  return scenario;
}

double identification_duration_s(const ArmScenario& scenario) {
  double t = kStartHold_s;
  for (const Leg& l : legs_of(*scenario.identification)) t += l.move_s + l.hold_s;
  return t;
}

std::vector<std::string> identification_log_columns(const ArmScenario& scenario) {
  std::vector<std::string> c = {"t_s"};
  for (std::size_t j = 0; j < scenario.controller.joints.size(); ++j) {
    for (const char* f : hardware::kSensorColumns) c.push_back(fmt::format("{}_{}", arm_log_prefix(scenario, j), f));
    for (const char* f : hardware::kCommandColumns) c.push_back(fmt::format("{}_{}", arm_log_prefix(scenario, j), f));
  }
  c.push_back("limit_flags");
  return c;
}

namespace {

/// One row of identification_log_columns().
void identification_log_row(const io::SensorState& state, const io::Command& sent, std::size_t io_count, std::uint32_t flags,
                            std::vector<double>& row) noexcept {
  std::size_t c = 0;
  row[c++] = state.time_s;
  for (std::size_t i = 0; i < io_count; ++i) {
    for (const double v : hardware::sensor_columns(state.joints[i])) row[c++] = v;
    for (const double v : hardware::command_columns(sent.joints[i])) row[c++] = v;
  }
  row[c] = static_cast<double>(flags);
}

/// One sample of an averaging window into its sums: every encoder, and per swept joint the load
/// cells less their zero, the motor's command and the filtered speed.
void add_to_window(IdentificationRecording::Sums& s, const io::SensorState& state, const io::Command& sent,
                   const control::ArmController& controller, const std::vector<std::size_t>& swept) noexcept {
  for (std::size_t i = 0; i < s.q.size(); ++i) s.q[i] += state.joints[i].angle_rad;
  for (std::size_t k = 0; k < swept.size(); ++k) {
    const std::size_t j = swept[k];
    const io::JointSensors& js = state.joints[j];
    s.force[k][0] += js.agonist_loadcell_N - controller.loadcell_offset_N(j, 0);
    s.force[k][1] += js.antagonist_loadcell_N - controller.loadcell_offset_N(j, 1);
    s.motor[k] += sent.joints[j].motor_torque_Nm;
    s.speed[k] += controller.diagnostics()[j].velocity_radps;
  }
  s.n += 1;
}

}  // namespace

IdentificationRecording record_identification(const ArmScenario& scenario, io::Backend& backend,
                                              const std::function<void(const std::string&)>& progress, const runtime::CycleHooks& hooks,
                                              runtime::RowSink* log) {
  const ArmScenario::Identification& id = *scenario.identification;
  const std::vector<std::size_t>& swept = id.joints;  // io joints the rig sweeps and measures
  const std::size_t n = swept.size(), io_count = scenario.controller.joints.size();
  const std::vector<Leg> legs = legs_of(id);
  std::vector<double> leg_start_s;
  double t = kStartHold_s;
  for (const Leg& l : legs) {
    leg_start_s.push_back(t);
    t += l.move_s + l.hold_s;
  }
  const double duration_s = t;

  IdentificationRecording rec;
  control::ArmControllerModel rig_controller = scenario.controller;
  rig_controller.allocation.pam_cutoff_Hz = id.pam_cutoff_Hz;  // the sweep's own (id.pam_cutoff_Hz)
  rec.controller = std::make_unique<control::ArmController>(rig_controller);
  control::ArmController& controller = *rec.controller;
  for (const std::size_t i : swept) controller.set_mode(i, control::ArmJointMode::kCommanded);
  const safety::JointModels joints = arm_joint_models(controller.model());
  // The drift check's premise - a still joint holds its force - is what the rig breaks on purpose:
  // stiction holds a swept joint while the PD ramps its force (cable friction x1.5: the sums reached
  // 100 N at 12.2 s, with the rate gate at 40 N/s still at 101 s). Every other check stays; a drifting
  // cell is the fit's to refuse (ArmIdentification.RefusesADriftingLoadCell).
  safety::LimitsModel limits = scenario.limits;
  limits.monitor.unmodelled |= safety::kFaultLoadcellDrift;
  safety::LimitedBackend limited(backend, limits, joints);

  const IdentificationRecording::Sums empty{std::vector<double>(io_count, 0.0), std::vector<std::array<double, 2>>(n, {0.0, 0.0}),
                                            std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), 0.0};
  std::vector<std::array<IdentificationRecording::Sums, 2>>& sums = rec.sums;
  sums.assign(id.postures.size(), {empty, empty});
  std::vector<double> start_q(n, 0.0);
  bool started = false;
  std::size_t leg = 0;
  int reported = -1;
  // The rig's friction feed-forward per sweep direction and swept joint (Nm): what the PD had to add
  // in the last window of that direction, learned with friction_learning_gain. It keeps the lag behind
  // the reference small and the wires sliding steadily through the window; without it the PD's lag
  // (the friction over its stiffness, 5-6 deg on the shoulder) let the joint stick and slip in the window.
  std::vector<std::array<double, 2>> feedforward_Nm(n, {0.0, 0.0});
  std::vector<double> pd_sum_Nm(n, 0.0), previous_ref(n, 0.0);
  double pd_n = 0;
  bool have_previous_ref = false;

  io::SensorState state;
  io::Command command;
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  auto hold = [](std::size_t) {};
  auto step = [&](std::size_t) {
    const double now = state.time_s;
    if (now >= kStartHold_s) {
      if (!started) {  // the rig's reference starts where the operator left the arm
        for (std::size_t k = 0; k < n; ++k) start_q[k] = state.joints[swept[k]].angle_rad;
        started = true;
      }
      while (leg + 1 < legs.size() && now >= leg_start_s[leg + 1]) {
        const Leg& done = legs[leg];
        if (done.sweep && pd_n > 0) {
          for (std::size_t k = 0; k < n; ++k) feedforward_Nm[k][static_cast<std::size_t>(done.side)] += id.friction_learning_gain * pd_sum_Nm[k] / pd_n;
        }
        std::fill(pd_sum_Nm.begin(), pd_sum_Nm.end(), 0.0);
        pd_n = 0;
        ++leg;
      }
      const Leg& l = legs[leg];
      const std::vector<double>& from = leg ? legs[leg - 1].target_rad : start_q;
      const double in_leg_s = now - leg_start_s[leg];
      const double s = l.sweep ? cruise(in_leg_s, l.move_s, id.ramp_s) : min_jerk(in_leg_s / l.move_s);
      const bool in_window = l.sweep && in_leg_s >= l.window_from_s && in_leg_s < l.window_to_s;
      for (std::size_t k = 0; k < n; ++k) {
        const std::size_t j = swept[k];
        const double ref = from[k] + (l.target_rad[k] - from[k]) * s;
        const double ref_velocity = have_previous_ref ? (ref - previous_ref[k]) / scenario.period_s : 0.0;
        previous_ref[k] = ref;
        const auto& d = controller.diagnostics()[j];
        const double pd = id.stiffness_Nm_per_rad[k] * (ref - state.joints[j].angle_rad) + id.damping_Nms_per_rad[k] * (ref_velocity - d.velocity_radps);
        const double cruising = l.sweep ? std::clamp(std::abs(ref_velocity) / id.sweep_speed_radps, 0.0, 1.0) : 0.0;
        const double feedforward = l.sweep ? cruising * feedforward_Nm[k][static_cast<std::size_t>(l.side)] : 0.0;
        if (in_window) pd_sum_Nm[k] += pd;
        controller.set_desired_torque(j, d.torque_gravity_Nm + feedforward + pd);
      }
      if (in_window) pd_n += 1;
      have_previous_ref = true;
    } else {
      for (const std::size_t j : swept) controller.set_desired_torque(j, controller.diagnostics()[j].torque_gravity_Nm);
    }
    controller.update(state, command);
  };
  std::vector<double> row(log ? identification_log_columns(scenario).size() : 0);
  auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t flags) {
    if (log) {
      identification_log_row(state, sent, io_count, flags, row);
      log->push_row(row);
    }
    if (!started) return;
    const Leg& l = legs[leg];
    const double in_leg_s = state.time_s - leg_start_s[leg];
    if (l.posture < 0 || in_leg_s < l.window_from_s || in_leg_s >= l.window_to_s) return;
    add_to_window(sums[static_cast<std::size_t>(l.posture)][static_cast<std::size_t>(l.side)], state, sent, controller, swept);
    if (progress && l.side == 1 && l.posture != reported && in_leg_s >= l.window_to_s - 2 * scenario.period_s) {
      reported = l.posture;
      progress(fmt::format("posture {}/{} '{}' measured sweeping up and down", l.posture + 1, id.postures.size(),
                           id.postures[static_cast<std::size_t>(l.posture)].name));
    }
  };
  const auto wall_start = std::chrono::steady_clock::now();
  runtime::run_cycles(limited, runtime::with_lifecycle(hooks, scenario.lifecycle), steps, state, command, step, hold, observe);
  rec.faults = limited.monitor().count();
  rec.fault_reason = limited.monitor().run_reason();
  rec.duration_s = duration_s;
  rec.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return rec;
}

ArmIdentificationResult fit_identification(const ArmScenario& scenario, const IdentificationRecording& rec) {
  // A fault the supervisor latched changed the outputs (hold, descend or vent): the torques measured
  // after it are not the controller's, and a fit to them would be wrong without saying why.
  if (rec.faults) {
    throw calibration::GravityIdentificationRejected(
        fmt::format("the supervisor latched {} fault(s) during the identification run (first: {}); the measurements after it are "
                    "not the controller's. Find the fault (docs/safety.md) and run again",
                    rec.faults, rec.fault_reason));
  }
  const ArmScenario::Identification& id = *scenario.identification;
  const std::vector<std::size_t>& swept = id.joints;
  const std::size_t n = swept.size(), io_count = scenario.controller.joints.size();
  const control::ArmController& controller = *rec.controller;
  const std::vector<std::array<IdentificationRecording::Sums, 2>>& sums = rec.sums;

  ArmIdentificationResult r;
  r.duration_s = rec.duration_s;
  r.realtime_factor = rec.duration_s / std::max(rec.wall_s, 1e-9);
  for (const std::size_t j : swept) r.joint_names.push_back(scenario.plant.actuated[j]);
  const int dof = scenario.controller.arm.dof();
  auto model_joint = [&](std::size_t io_joint) { return scenario.controller.joints[io_joint].model_joint; };
  for (std::size_t p = 0; p < id.postures.size(); ++p) {
    IdentificationMeasurement m;
    m.name = id.postures[p].name;
    m.joints.resize(n);
    calibration::GravitySample sample;
    sample.name = m.name;
    sample.q_rad = Eigen::VectorXd::Zero(dof);  // the passive wrist joints are taken at 0, as the controller does
    sample.tau_Nm = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    for (int side = 0; side < 2; ++side) {
      const IdentificationRecording::Sums& s = sums[p][static_cast<std::size_t>(side)];
      if (s.n < 1) throw std::runtime_error(fmt::format("identification: posture '{}' was not measured (run too short?)", m.name));
      m.q_deg[side].resize(io_count);
      for (std::size_t i = 0; i < io_count; ++i) {
        m.q_deg[side][i] = models::rad_to_deg(s.q[i] / s.n);
        sample.q_rad[model_joint(i)] += 0.5 * s.q[i] / s.n;
      }
      for (std::size_t k = 0; k < n; ++k) {
        IdentificationJoint& mj = m.joints[k];
        const double r0 = controller.model().joints[swept[k]].actuator.pulley_radius_m;
        mj.force_N[side][0] = s.force[k][0] / s.n;
        mj.force_N[side][1] = s.force[k][1] / s.n;
        mj.motor_Nm[side] = s.motor[k] / s.n;
        mj.tau_Nm[side] = r0 * (mj.force_N[side][0] - mj.force_N[side][1]) + mj.motor_Nm[side];
        mj.speed_fraction[side] = (side == 0 ? 1.0 : -1.0) * s.speed[k] / s.n / id.sweep_speed_radps;
        // A joint the cables held during the window measures the static friction's band, not sliding.
        if (!(mj.speed_fraction[side] >= id.min_speed_fraction)) {
          throw calibration::GravityIdentificationRejected(fmt::format(
              "gravity identification refused: at posture '{}' {} moved at {:.0f} % of the reference's speed in the window of "
              "the {} sweep (< {:.0f} %, min_speed_fraction): the cables held it, so its torque is not the sliding one. Stiffen the "
              "rig's PD or slow the sweep",
              m.name, r.joint_names[k], 100 * mj.speed_fraction[side], side == 0 ? "upward" : "downward", 100 * id.min_speed_fraction));
        }
      }
    }
    r.measurements.push_back(m);
    r.samples.push_back(sample);
  }
  calibration::GravityIdentificationOptions o;
  o.joints.clear();
  for (const std::size_t j : swept) o.joints.push_back(model_joint(j));
  o.max_residual_rms_Nm = id.max_residual_rms_Nm;
  o.max_change_fraction = id.max_change_fraction;
  o.rank_tolerance = id.rank_tolerance;
  // Each posture's torques from the two sweeps' measurements, with the gravity model `theta`
  // carrying each sweep from where the joints were in its window to the sweeps' mean posture: the PD
  // lags the reference by the friction over its stiffness, so the arm is a few degrees below the
  // posture going up and above it coming down, and the elbow's gravity changes by up to 1.5 Nm
  // between the two. The correction uses the model; its error is the model's error in gravity's
  // slope over those few degrees, and two passes with the identified model settle it.
  const models::ArmModel& arm = scenario.controller.arm;
  models::ArmData data(arm);
  Eigen::MatrixXd Y(dof, models::gravity_parameter_count(arm));
  auto gravity_Nm = [&](const Eigen::VectorXd& theta, const std::vector<double>& q_deg) -> Eigen::VectorXd {  // per swept joint
    Eigen::VectorXd q = Eigen::VectorXd::Zero(dof);
    for (std::size_t i = 0; i < io_count; ++i) q[model_joint(i)] = models::deg_to_rad(q_deg[i]);
    models::gravity_regressor(arm, data, q, Y);
    const Eigen::VectorXd all = Y * theta;
    Eigen::VectorXd g(static_cast<Eigen::Index>(n));
    for (std::size_t k = 0; k < n; ++k) g[static_cast<Eigen::Index>(k)] = all[model_joint(swept[k])];
    return g;
  };
  auto measure = [&](const Eigen::VectorXd& theta) {
    for (std::size_t p = 0; p < r.measurements.size(); ++p) {
      IdentificationMeasurement& m = r.measurements[p];
      std::vector<double> q_mean_deg(io_count);
      for (std::size_t i = 0; i < io_count; ++i) q_mean_deg[i] = 0.5 * (m.q_deg[0][i] + m.q_deg[1][i]);
      const Eigen::VectorXd g_mean = gravity_Nm(theta, q_mean_deg), g_up = gravity_Nm(theta, m.q_deg[0]),
                            g_down = gravity_Nm(theta, m.q_deg[1]);
      for (std::size_t k = 0; k < n; ++k) {
        IdentificationJoint& mj = m.joints[k];
        const auto e = static_cast<Eigen::Index>(k);
        const double r0 = controller.model().joints[swept[k]].actuator.pulley_radius_m;
        const double a_up = r0 * mj.force_N[0][0], b_up = r0 * mj.force_N[0][1];
        const double a_down = r0 * mj.force_N[1][0], b_down = r0 * mj.force_N[1][1];
        const double m_up = mj.motor_Nm[0] - (g_up[e] - g_mean[e]);
        const double m_down = mj.motor_Nm[1] - (g_down[e] - g_mean[e]);
        const double ratio = capstan_ratio(a_up, b_up, m_up, a_down, b_down, m_down);
        mj.friction_ratio = ratio;
        mj.tau_mean_Nm = 0.5 * ((a_up / ratio - b_up * ratio + m_up) + (a_down * ratio - b_down / ratio + m_down));
        r.samples[p].tau_Nm[e] = mj.tau_mean_Nm;
      }
    }
  };
  Eigen::VectorXd theta = models::gravity_parameters(arm);
  for (int pass = 0; pass < 3; ++pass) {
    measure(theta);
    if (pass < 2) {
      try {
        theta = calibration::identify_gravity(arm, r.samples, o).theta;
      } catch (const calibration::GravityIdentificationRejected&) {
        break;  // judged below, on the measurement so far
      }
    }
  }
  r.fit = calibration::identify_gravity(arm, r.samples, o);
  r.identified = models::with_gravity_parameters(scenario.controller.arm, r.fit.theta);
  return r;
}

IdentificationRealtimeResult record_identification_realtime(const ArmScenario& scenario, const HardwareRunOptions& options,
                                                            const std::filesystem::path& cycles_log,
                                                            const std::function<void(const std::string&)>& progress) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  IdentificationRealtimeResult res;
  static_cast<BoardRunResult&>(res) = run_on_hardware(
      arm_hardware(scenario, identification_plant_params(scenario, scenario.plant)), scenario.lifecycle, options,
      {"identification", identification_duration_s(scenario), cycles_log, identification_log_columns(scenario),
       {"peha identify-gravity: the rig procedure, every control cycle"}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        res.recording = record_identification(scenario, *hw.backend, progress, hooks, &sink);
        return res.verdict;
      });
  return res;
}

}  // namespace peha::experiments
