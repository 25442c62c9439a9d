#include "peha/experiments/arm_identification/arm_identification.hpp"

#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/models/gravity_parameters.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>

namespace peha::experiments {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kStartHold_s = 2.0;  // the operator holds the start posture while compensation comes on (as E3)

/// One leg of the rig's reference: a move to `target` over move_s (minimum jerk, or for a sweep a
/// cruise at constant speed between two ramps), then a hold of hold_s. A sweep measures posture
/// `posture` (-1: none, a warm-up) in direction `side` (0 up, 1 down) while the leg's clock is in
/// [window_from_s, window_to_s].
struct Leg {
  double target_rad[2] = {0, 0};
  double move_s = 1, hold_s = 0;
  bool sweep = false;
  int posture = -1, side = -1;
  double window_from_s = 0, window_to_s = 0;
};

std::vector<Leg> legs_of(const ArmScenario::Identification& id) {
  std::vector<Leg> legs;
  const double sweep_s = 2 * id.sweep_rad / id.sweep_speed_radps + id.ramp_s;  // cruise + one ramp's worth of distance lost to two
  const double half_window_s = id.window_rad / id.sweep_speed_radps;
  for (std::size_t p = 0; p < id.postures.size(); ++p) {
    const ArmPosture& a = id.postures[p];
    legs.push_back({{a.target_rad[0] - id.sweep_rad, a.target_rad[1] - id.sweep_rad}, id.move_s, id.settle_s});
    // The first posture is swept once more before it is measured: the rig learns the friction it
    // must push against (below) on that pair.
    for (int pass = p == 0 ? 0 : 1; pass < 2; ++pass) {
      for (int side = 0; side < 2; ++side) {
        const double to = side == 0 ? id.sweep_rad : -id.sweep_rad;  // up, then back down
        legs.push_back({{a.target_rad[0] + to, a.target_rad[1] + to}, sweep_s, id.settle_s, true, pass == 1 ? static_cast<int>(p) : -1, side,
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
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p.operator_hands.moves.push_back({"start", 0.0, kStartHold_s, kStartHold_s, {p.initial_q_rad[0], p.initial_q_rad[1], nan}});
  (void)scenario;
  return p;
}

ArmIdentificationResult identify_arm_gravity(const ArmScenario& given, const sim::ArmPlantParams& plant_params,
                                             const std::function<void(const std::string&)>& progress) {
  // Always from the body file's prior, whatever identification the scenario's controller already
  // uses: the rig's gravity compensation and the fit's prior do not depend on an earlier result (a
  // rerun on the shipped config reproduces the shipped file, and the robustness matrix identifies
  // each variant as a new rig would).
  ArmScenario scenario = given;
  scenario.controller.arm = scenario.nominal_arm;
  if (!scenario.identification) throw config::Error("the arm scenario has no identification: section (docs/identification.md)");
  const ArmScenario::Identification& id = *scenario.identification;
  const std::vector<Leg> legs = legs_of(id);
  std::vector<double> leg_start_s;
  double t = kStartHold_s;
  for (const Leg& l : legs) {
    leg_start_s.push_back(t);
    t += l.move_s + l.hold_s;
  }
  const double duration_s = t;

  std::unique_ptr<sim::ArmBackend> owned;
  {
    const std::lock_guard lock(mujoco_load_mutex());  // MuJoCo's model loading is not thread-safe
    owned = std::make_unique<sim::ArmBackend>(identification_plant_params(scenario, plant_params));
  }
  sim::ArmBackend& plant = *owned;
  control::ArmController controller(scenario.controller);
  controller.set_mode(0, control::ArmJointMode::kCommanded);
  controller.set_mode(1, control::ArmJointMode::kCommanded);
  const safety::JointModels joints = arm_joint_models(controller.model());
  safety::LimitedBackend limited(plant, scenario.limits, joints);

  // Per posture and side: sums over the averaging window.
  struct Sums {
    double q[3] = {0, 0, 0}, force[2][2] = {{0, 0}, {0, 0}}, motor[2] = {0, 0}, speed[2] = {0, 0};
    double n = 0;
  };
  std::vector<std::array<Sums, 2>> sums(id.postures.size());
  double start_q[2] = {0, 0};
  bool started = false;
  std::size_t leg = 0;
  int reported = -1;
  // The rig's friction feed-forward per sweep direction and joint (Nm): what the PD had to add in the
  // last window of that direction, learned with friction_learning_gain. It keeps the lag behind the
  // reference small and the wires sliding steadily through the window; without it the PD's lag (the
  // friction over its stiffness, 5-6 deg on the shoulder) let the joint stick and slip in the window.
  double feedforward_Nm[2][2] = {{0, 0}, {0, 0}};
  double pd_sum_Nm[2] = {0, 0}, pd_n = 0;
  double previous_ref[2] = {0, 0};
  bool have_previous_ref = false;

  io::SensorState state;
  io::Command command;
  const auto steps = static_cast<std::size_t>(std::llround(duration_s / scenario.period_s));
  auto hold = [](std::size_t) {};
  auto step = [&](std::size_t) {
    const double now = state.time_s;
    if (now >= kStartHold_s) {
      if (!started) {  // the rig's reference starts where the operator left the arm
        start_q[0] = state.joints[0].angle_rad;
        start_q[1] = state.joints[1].angle_rad;
        started = true;
      }
      while (leg + 1 < legs.size() && now >= leg_start_s[leg + 1]) {
        const Leg& done = legs[leg];
        if (done.sweep && pd_n > 0) {
          for (int j = 0; j < 2; ++j) feedforward_Nm[done.side][j] += id.friction_learning_gain * pd_sum_Nm[j] / pd_n;
        }
        pd_sum_Nm[0] = pd_sum_Nm[1] = pd_n = 0;
        ++leg;
      }
      const Leg& l = legs[leg];
      const double* from = leg ? legs[leg - 1].target_rad : start_q;
      const double in_leg_s = now - leg_start_s[leg];
      const double s = l.sweep ? cruise(in_leg_s, l.move_s, id.ramp_s) : min_jerk(in_leg_s / l.move_s);
      const bool in_window = l.sweep && in_leg_s >= l.window_from_s && in_leg_s < l.window_to_s;
      for (int j = 0; j < 2; ++j) {
        const double ref = from[j] + (l.target_rad[j] - from[j]) * s;
        const double ref_velocity = have_previous_ref ? (ref - previous_ref[j]) / scenario.period_s : 0.0;
        previous_ref[j] = ref;
        const auto& d = controller.diagnostics()[static_cast<std::size_t>(j)];
        const double pd = id.stiffness_Nm_per_rad[j] * (ref - state.joints[j].angle_rad) + id.damping_Nms_per_rad[j] * (ref_velocity - d.velocity_radps);
        const double cruising = l.sweep ? std::clamp(std::abs(ref_velocity) / id.sweep_speed_radps, 0.0, 1.0) : 0.0;
        const double feedforward = l.sweep ? cruising * feedforward_Nm[l.side][j] : 0.0;
        if (in_window) pd_sum_Nm[j] += pd;
        controller.set_desired_torque(j, d.torque_gravity_Nm + feedforward + pd);
      }
      if (in_window) pd_n += 1;
      have_previous_ref = true;
    } else {
      for (int j = 0; j < 2; ++j) controller.set_desired_torque(j, controller.diagnostics()[static_cast<std::size_t>(j)].torque_gravity_Nm);
    }
    controller.update(state, command);
  };
  auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t) {
    if (!started) return;
    const Leg& l = legs[leg];
    const double in_leg_s = state.time_s - leg_start_s[leg];
    if (l.posture < 0 || in_leg_s < l.window_from_s || in_leg_s >= l.window_to_s) return;
    Sums& s = sums[static_cast<std::size_t>(l.posture)][static_cast<std::size_t>(l.side)];
    for (int j = 0; j < 3; ++j) s.q[j] += state.joints[j].angle_rad;
    for (int j = 0; j < 2; ++j) {
      const io::JointSensors& js = state.joints[j];
      s.force[j][0] += js.agonist_loadcell_N - controller.loadcell_offset_N(static_cast<std::size_t>(j), 0);
      s.force[j][1] += js.antagonist_loadcell_N - controller.loadcell_offset_N(static_cast<std::size_t>(j), 1);
      s.motor[j] += sent.joints[j].motor_torque_Nm;
      s.speed[j] += controller.diagnostics()[static_cast<std::size_t>(j)].velocity_radps;
    }
    s.n += 1;
    if (progress && l.side == 1 && l.posture != reported && in_leg_s >= l.window_to_s - 2 * scenario.period_s) {
      reported = l.posture;
      progress(fmt::format("posture {}/{} '{}' measured sweeping up and down", l.posture + 1, id.postures.size(),
                           id.postures[static_cast<std::size_t>(l.posture)].name));
    }
  };
  const auto wall_start = std::chrono::steady_clock::now();
  runtime::run_cycles(limited, {}, steps, state, command, step, hold, observe);
  // A fault the supervisor latched changed the outputs (hold, descend or vent): the torques measured
  // after it are not the controller's, and a fit to them would be wrong without saying why.
  if (limited.monitor().count()) {
    throw calibration::GravityIdentificationRejected(
        fmt::format("the supervisor latched {} fault(s) during the identification run (first: {}); the measurements after it are "
                    "not the controller's. Find the fault (docs/safety.md) and run again",
                    limited.monitor().count(), limited.monitor().run_reason()));
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  ArmIdentificationResult r;
  r.duration_s = duration_s;
  r.realtime_factor = duration_s / std::max(wall_s, 1e-9);
  const int dof = scenario.controller.arm.dof();
  for (std::size_t p = 0; p < id.postures.size(); ++p) {
    IdentificationMeasurement m;
    m.name = id.postures[p].name;
    calibration::GravitySample sample;
    sample.name = m.name;
    sample.q_rad = Eigen::VectorXd::Zero(dof);  // the passive wrist joints are taken at 0, as the controller does
    sample.tau_Nm = Eigen::VectorXd::Zero(2);
    for (int side = 0; side < 2; ++side) {
      const Sums& s = sums[p][static_cast<std::size_t>(side)];
      if (s.n < 1) throw std::runtime_error(fmt::format("identification: posture '{}' was not measured (run too short?)", m.name));
      for (int j = 0; j < 3; ++j) {
        m.q_deg[side][j] = s.q[j] / s.n / kDeg;
        sample.q_rad[j] += 0.5 * s.q[j] / s.n;
      }
      for (int j = 0; j < 2; ++j) {
        const double r0 = controller.model().joints[static_cast<std::size_t>(j)].actuator.pulley_radius_m;
        m.force_N[side][j][0] = s.force[j][0] / s.n;
        m.force_N[side][j][1] = s.force[j][1] / s.n;
        m.motor_Nm[side][j] = s.motor[j] / s.n;
        m.tau_Nm[side][j] = r0 * (m.force_N[side][j][0] - m.force_N[side][j][1]) + m.motor_Nm[side][j];
        m.speed_fraction[side][j] = (side == 0 ? 1.0 : -1.0) * s.speed[j] / s.n / id.sweep_speed_radps;
        // A joint the cables held during the window measures the static friction's band, not sliding.
        if (!(m.speed_fraction[side][j] >= id.min_speed_fraction)) {
          throw calibration::GravityIdentificationRejected(fmt::format(
              "gravity identification refused: at posture '{}' the {} moved at {:.0f} % of the reference's speed in the window of "
              "the {} sweep (< {:.0f} %, min_speed_fraction): the cables held it, so its torque is not the sliding one. Stiffen the "
              "rig's PD or slow the sweep",
              m.name, j == 0 ? "shoulder" : "elbow", 100 * m.speed_fraction[side][j],
              side == 0 ? "upward" : "downward", 100 * id.min_speed_fraction));
        }
      }
    }
    r.measurements.push_back(m);
    r.samples.push_back(sample);
  }
  calibration::GravityIdentificationOptions o;
  o.joints = {0, 1};
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
  auto gravity_Nm = [&](const Eigen::VectorXd& theta, const double* q_deg) -> Eigen::Vector2d {  // SFE, EFE
    Eigen::VectorXd q = Eigen::VectorXd::Zero(dof);
    for (int j = 0; j < 3; ++j) q[j] = q_deg[j] * kDeg;
    models::gravity_regressor(arm, data, q, Y);
    return Y.topRows(2) * theta;
  };
  auto measure = [&](const Eigen::VectorXd& theta) {
    for (std::size_t p = 0; p < r.measurements.size(); ++p) {
      IdentificationMeasurement& m = r.measurements[p];
      double q_mean_deg[3];
      for (int j = 0; j < 3; ++j) q_mean_deg[j] = 0.5 * (m.q_deg[0][j] + m.q_deg[1][j]);
      const Eigen::Vector2d g_mean = gravity_Nm(theta, q_mean_deg), g_up = gravity_Nm(theta, m.q_deg[0]),
                            g_down = gravity_Nm(theta, m.q_deg[1]);
      for (int j = 0; j < 2; ++j) {
        const double r0 = controller.model().joints[static_cast<std::size_t>(j)].actuator.pulley_radius_m;
        const double a_up = r0 * m.force_N[0][j][0], b_up = r0 * m.force_N[0][j][1];
        const double a_down = r0 * m.force_N[1][j][0], b_down = r0 * m.force_N[1][j][1];
        const double m_up = m.motor_Nm[0][j] - (g_up[j] - g_mean[j]);
        const double m_down = m.motor_Nm[1][j] - (g_down[j] - g_mean[j]);
        const double k = capstan_ratio(a_up, b_up, m_up, a_down, b_down, m_down);
        m.friction_ratio[j] = k;
        m.tau_mean_Nm[j] = 0.5 * ((a_up / k - b_up * k + m_up) + (a_down * k - b_down / k + m_down));
        r.samples[p].tau_Nm[j] = m.tau_mean_Nm[j];
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

}  // namespace peha::experiments
