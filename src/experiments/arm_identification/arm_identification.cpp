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

/// One leg of the rig's reference: a minimum-jerk move to `target` over move_s, then a hold; the
/// last average_s of the hold is a measurement of posture `posture` from `side` (-1: none).
struct Leg {
  double target_rad[2] = {0, 0};
  double move_s = 1, hold_s = 0;
  int posture = -1, side = -1;
};

std::vector<Leg> legs_of(const ArmScenario::Identification& id) {
  std::vector<Leg> legs;
  for (std::size_t p = 0; p < id.postures.size(); ++p) {
    const ArmPosture& a = id.postures[p];
    for (int side = 0; side < 2; ++side) {
      const double offset = side == 0 ? id.approach_rad : -id.approach_rad;  // above, then below
      legs.push_back({{a.sfe_rad + offset, a.efe_rad + offset}, id.move_s, 0.5, -1, -1});
      legs.push_back({{a.sfe_rad, a.efe_rad}, id.approach_s, id.settle_s + id.average_s, static_cast<int>(p), side});
    }
  }
  return legs;
}

double min_jerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
}

}  // namespace

sim::RightArmPlantParams identification_plant_params(const ArmScenario& scenario, const sim::RightArmPlantParams& plant) {
  sim::RightArmPlantParams p = plant;
  p.operator_hands.moves.clear();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p.operator_hands.moves.push_back({"start", 0.0, kStartHold_s, kStartHold_s, {p.initial_q_rad[0], p.initial_q_rad[1], nan}});
  (void)scenario;
  return p;
}

ArmIdentificationResult identify_arm_gravity(const ArmScenario& scenario, const sim::RightArmPlantParams& plant_params,
                                             const std::function<void(const std::string&)>& progress) {
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

  std::unique_ptr<sim::RightArmBackend> owned;
  {
    const std::lock_guard lock(mujoco_load_mutex());  // MuJoCo's model loading is not thread-safe
    owned = std::make_unique<sim::RightArmBackend>(identification_plant_params(scenario, plant_params));
  }
  sim::RightArmBackend& plant = *owned;
  control::ArmController controller(scenario.controller);
  controller.set_mode(0, control::ArmJointMode::kCommanded);
  controller.set_mode(1, control::ArmJointMode::kCommanded);
  const safety::JointModels joints = arm_joint_models(controller.model());
  safety::LimitedBackend limited(plant, scenario.limits, joints);

  // Per posture and side: sums over the averaging window.
  struct Sums {
    double q[3] = {0, 0, 0}, force[2][2] = {{0, 0}, {0, 0}}, motor[2] = {0, 0};
    double n = 0;
  };
  std::vector<std::array<Sums, 2>> sums(id.postures.size());
  double start_q[2] = {0, 0};
  bool started = false;
  std::size_t leg = 0;
  int reported = -1;

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
      while (leg + 1 < legs.size() && now >= leg_start_s[leg + 1]) ++leg;
      const Leg& l = legs[leg];
      const double* from = leg ? legs[leg - 1].target_rad : start_q;
      const double s = min_jerk((now - leg_start_s[leg]) / l.move_s);
      for (int j = 0; j < 2; ++j) {
        const double ref = from[j] + (l.target_rad[j] - from[j]) * s;
        const double error = ref - state.joints[j].angle_rad;
        const auto& d = controller.diagnostics()[static_cast<std::size_t>(j)];
        controller.set_desired_torque(j, d.torque_gravity_Nm + id.stiffness_Nm_per_rad[j] * error - id.damping_Nms_per_rad[j] * d.velocity_radps);
      }
    } else {
      for (int j = 0; j < 2; ++j) controller.set_desired_torque(j, controller.diagnostics()[static_cast<std::size_t>(j)].torque_gravity_Nm);
    }
    controller.update(state, command);
  };
  auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t) {
    if (!started) return;
    const Leg& l = legs[leg];
    const double end_s = leg_start_s[leg] + l.move_s + l.hold_s;
    if (l.posture < 0 || state.time_s < end_s - id.average_s) return;
    Sums& s = sums[static_cast<std::size_t>(l.posture)][static_cast<std::size_t>(l.side)];
    for (int j = 0; j < 3; ++j) s.q[j] += state.joints[j].angle_rad;
    for (int j = 0; j < 2; ++j) {
      const io::JointSensors& js = state.joints[j];
      s.force[j][0] += js.agonist_loadcell_N - controller.loadcell_offset_N(static_cast<std::size_t>(j), 0);
      s.force[j][1] += js.antagonist_loadcell_N - controller.loadcell_offset_N(static_cast<std::size_t>(j), 1);
      s.motor[j] += sent.joints[j].motor_torque_Nm;
    }
    s.n += 1;
    if (progress && l.side == 1 && l.posture != reported && state.time_s >= end_s - 2 * scenario.period_s) {
      reported = l.posture;
      progress(fmt::format("posture {}/{} '{}' measured from above and below", l.posture + 1, id.postures.size(),
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
    sample.uncertainty_Nm = Eigen::VectorXd::Zero(2);
    double motor_mean[2] = {0, 0};
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
        m.tau_Nm[side][j] = r0 * (m.force_N[side][j][0] - m.force_N[side][j][1]) + s.motor[j] / s.n;
        motor_mean[j] += 0.5 * s.motor[j] / s.n;
      }
    }
    for (int j = 0; j < 2; ++j) {
      const double r0 = controller.model().joints[static_cast<std::size_t>(j)].actuator.pulley_radius_m;
      double f[2];
      for (int mu = 0; mu < 2; ++mu) {
        const double a = m.force_N[0][j][mu], b = m.force_N[1][j][mu];
        f[mu] = a > 0 && b > 0 ? std::sqrt(a * b) : 0.5 * (a + b);  // capstan: T e^x and T e^-x average to T
      }
      m.tau_mean_Nm[j] = r0 * (f[0] - f[1]) + motor_mean[j];
      sample.tau_Nm[j] = m.tau_mean_Nm[j];
      // Half the band the cables' friction held the joint in: what this row's mean is uncertain by.
      sample.uncertainty_Nm[j] = 0.5 * std::abs(m.tau_Nm[1][j] - m.tau_Nm[0][j]);
    }
    r.measurements.push_back(m);
    r.samples.push_back(sample);
  }
  calibration::GravityIdentificationOptions o;
  o.joints = {0, 1};
  o.max_residual_rms_Nm = id.max_residual_rms_Nm;
  o.max_change_fraction = id.max_change_fraction;
  o.rank_tolerance = id.rank_tolerance;
  r.fit = calibration::identify_gravity(scenario.controller.arm, r.samples, o);
  r.identified = models::with_gravity_parameters(scenario.controller.arm, r.fit.theta);
  return r;
}

}  // namespace peha::experiments
