#include "peha/experiments/e6_bandwidth/bandwidth.hpp"

#include "peha/control/arm_controller.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <tuple>
#include <utility>

namespace peha::experiments {
namespace {

/// Where the gain crosses `threshold` between two points, interpolated in log frequency.
double log_crossing_Hz(const BodePoint& a, const BodePoint& b, double threshold) {
  const double w = (a.gain - threshold) / (a.gain - b.gain);
  return std::exp(std::log(a.frequency_Hz) + w * (std::log(b.frequency_Hz) - std::log(a.frequency_Hz)));
}

/// Where the gain first falls below 1/sqrt(2), log-interpolated; the highest frequency if it never
/// does, the lowest if it is below already there (both with reached = false).
std::pair<double, bool> bandwidth_3dB_Hz(const std::vector<BodePoint>& bode) {
  const double threshold = 1.0 / std::sqrt(2.0);
  if (bode.front().gain < threshold) return {bode.front().frequency_Hz, false};
  for (std::size_t i = 1; i < bode.size(); ++i) {
    if (bode[i].gain < threshold && bode[i - 1].gain >= threshold) return {log_crossing_Hz(bode[i - 1], bode[i], threshold), true};
  }
  return {bode.back().frequency_Hz, false};
}

}  // namespace

PassBand pass_band_3dB(const std::vector<BodePoint>& bode) {
  const double threshold = 1.0 / std::sqrt(2.0);
  PassBand best;
  double best_width = -1.0;
  for (std::size_t i = 0; i < bode.size();) {
    if (bode[i].gain < threshold) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < bode.size() && bode[j + 1].gain >= threshold) ++j;
    PassBand b;
    b.open_low = i == 0;
    b.open_high = j + 1 == bode.size();
    b.low_Hz = b.open_low ? bode[i].frequency_Hz : log_crossing_Hz(bode[i - 1], bode[i], threshold);
    b.high_Hz = b.open_high ? bode[j].frequency_Hz : log_crossing_Hz(bode[j], bode[j + 1], threshold);
    const double width = std::log(b.high_Hz / b.low_Hz);
    if (width > best_width) best = b, best_width = width;
    i = j + 1;
  }
  return best;
}

BandwidthResult run_bandwidth(const ArmScenario& scenario, bool hybrid) {
  const ArmScenario::Bandwidth& b = scenario.bandwidth;
  sim::ArmPlantParams plant_params = scenario.plant;
  // A torque bench: every joint the posture names (the swept one among them) locked by an equality
  // constraint, so the delivered torque is the actuator's, not a motion's.
  for (std::size_t i = 0; i < b.locked_rad.size(); ++i) {
    if (std::isnan(b.locked_rad[i])) continue;
    const auto q = static_cast<std::size_t>(scenario.controller.joints[i].model_joint);
    plant_params.initial_q_rad.at(q) = b.locked_rad[i];
    sim::ArmMjcfJoint& joint = plant_params.mjcf.joints.at(q);
    joint.locked = true;
    joint.locked_at_rad = b.locked_rad[i];
  }
  sim::ArmBackend plant(plant_params);
  control::ArmControllerModel model = scenario.controller;
  model.allocation.use_motor = hybrid;
  // PAM-only: no motor to hand the fast part to, so no low-pass split either.
  if (!hybrid) model.allocation.pam_cutoff_Hz = 0.25 / scenario.period_s;
  control::ArmController controller(model);
  controller.set_mode(b.joint, control::ArmJointMode::kGravity);
  const safety::JointModels joints = arm_joint_models(controller.model());
  safety::LimitedBackend limited(plant, scenario.limits, joints);
  safety::Envelope envelope;
  const auto bench = static_cast<std::size_t>(b.joint);
  const double r0 = plant_params.actuators[bench].pulley_radius_m;

  BandwidthResult r;
  r.variant = hybrid ? "hybrid" : "pam_only";
  // The schedule: 2 s in gravity compensation to settle (its last gravity torque is the bias), then
  // per frequency whole cycles of bias + amplitude sin(2 pi f t); the first cycle is not analysed.
  struct Segment {
    double frequency_Hz;
    std::size_t start, total, n_cycle;
    std::complex<double> U = 0, Y = 0, Y_joint = 0;
  };
  const auto settle = static_cast<std::size_t>(2.0 / scenario.period_s);
  std::vector<Segment> segments;
  std::size_t end = settle;
  for (double f : b.frequencies_Hz) {
    const double cycles = std::ceil(std::max(b.min_cycles, b.min_duration_s * f));
    const auto n_cycle = static_cast<std::size_t>(std::llround(1.0 / (f * scenario.period_s)));
    segments.push_back({f, end, static_cast<std::size_t>(cycles) * n_cycle, n_cycle});
    end += segments.back().total;
  }
  double bias = 0.0, u = 0.0, phase = 0.0;
  std::size_t segment = 0;
  io::SensorState state;
  io::Command command;
  auto step = [&](std::size_t k) {
    if (k == settle) controller.set_mode(b.joint, control::ArmJointMode::kCommanded);
    if (k >= settle) {
      while (k >= segments[segment].start + segments[segment].total) ++segment;
      const Segment& sg = segments[segment];
      phase = 2.0 * std::numbers::pi * sg.frequency_Hz * static_cast<double>(k - sg.start) * scenario.period_s;
      u = b.amplitude_Nm * std::sin(phase);
      controller.set_desired_torque(b.joint, bias + u);
    }
    controller.update(state, command);
    if (k < settle) bias = controller.diagnostics()[bench].torque_gravity_Nm;
  };
  auto hold = [](std::size_t) {};
  auto observe = [&](std::size_t k, const io::Command& sent, std::uint32_t) {
    // A torque bench measures what the actuator delivers in answer to the command just sent: the
    // plant's truth after this cycle's write.
    const sim::ArmTruth& truth = plant.truth();
    for (std::size_t a = 0; a < static_cast<std::size_t>(state.joint_count); ++a) {
      safety::JointSample j = arm_joint_sample(state, sent, &truth, a);
      if (controller.wires_slack_on_purpose(state.time_s)) j.min_tension_N = std::numeric_limits<double>::infinity();  // start-up tare
      envelope.observe(a, j);
    }
    const sim::PehaJointTruth& j = truth.actuators[bench];
    r.peak_muscle_force_N = std::max({r.peak_muscle_force_N, j.muscle_force_N[0], j.muscle_force_N[1]});
    r.peak_motor_torque_Nm = std::max(r.peak_motor_torque_Nm, std::abs(j.motor_torque_Nm));
    if (k < settle) return;
    Segment& sg = segments[segment];
    const double y = r0 * (j.muscle_force_N[0] - j.muscle_force_N[1]) + j.motor_torque_Nm - bias;  // delivered, Nm
    // After the cable: the wires' joint-side tensions (capstan stick band with memory) + motor.
    const double y_joint = j.joint_torque_after_cable_Nm - bias;
    if (k >= sg.start + sg.n_cycle) {  // whole cycles after the first (transient)
      const std::complex<double> e = std::polar(1.0, -phase);
      sg.U += u * e;
      sg.Y += y * e;
      sg.Y_joint += y_joint * e;
    }
  };
  runtime::run_cycles(limited, runtime::resuming(runtime::with_lifecycle({}, scenario.lifecycle), [&controller] { controller.resume(); }), end - 1,
                      state, command, step, hold, observe);
  for (const Segment& sg : segments) {
    const std::complex<double> H = sg.Y / sg.U;
    r.bode.push_back({sg.frequency_Hz, std::abs(H), models::rad_to_deg(std::arg(H))});
    const std::complex<double> H_joint = sg.Y_joint / sg.U;
    r.bode_at_joint.push_back({sg.frequency_Hz, std::abs(H_joint), models::rad_to_deg(std::arg(H_joint))});
  }
  const safety::Envelope::Joint& e = envelope.joints[bench];
  r.min_wire_tension_N = e.min_tension_N;
  add_arm_envelope_checks(scenario, joints, envelope, r.verdict);
  safety::add_supervisor_check(limited.monitor(), r.verdict);
  std::tie(r.bandwidth_3dB_Hz, r.reached_3dB) = bandwidth_3dB_Hz(r.bode);
  std::tie(r.bandwidth_3dB_at_joint_Hz, r.reached_3dB_at_joint) = bandwidth_3dB_Hz(r.bode_at_joint);
  r.pass_band_at_joint = pass_band_3dB(r.bode_at_joint);
  // What the hybrid is for: torque the joint really receives, fast (PAM-only is not judged: its band
  // at the joint is none, the cables' stick band eats a small sine).
  if (hybrid && b.min_hybrid_band_at_joint_Hz > 0) {
    r.verdict.at_least("hybrid torque band at the joint, upper -3 dB edge", "Hz", r.pass_band_at_joint.empty() ? 0.0 : r.pass_band_at_joint.high_Hz,
                       b.min_hybrid_band_at_joint_Hz);
  }
  r.within_limits = r.verdict.passed();
  return r;
}

}  // namespace peha::experiments
