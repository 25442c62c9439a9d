#include "peha/experiments/e6_bandwidth/bandwidth.hpp"

#include "peha/control/arm_controller.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>

namespace peha::experiments {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

}  // namespace

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

}  // namespace peha::experiments
