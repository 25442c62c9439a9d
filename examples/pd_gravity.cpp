// Your own controller on peha (docs/user-controller.md): a joint-space PD around the posture the arm
// starts in, plus the controller's gravity model, at 1 kHz through peha's allocation, limits,
// plausibility monitor and lifecycle. Build: part of `make` (build/release/pd_gravity_example).
//
//   pd_gravity_example --config configs/right_arm.yaml                       # the simulated arm
//   pd_gravity_example --config configs/right_arm.yaml --backend udp://127.0.0.1:50000 --rt-priority 0
//                                                      # the board (here 'peha mfb-emulator --config ... --case free --port 50000')
//
// Gravity alone while peha's start-up runs (ArmState::starting), then it holds the arm where the
// start-up left it, moves every joint's target by --step-deg at half time, and prints the verdict and
// how far each joint ended from its target. Exit code 0 when the verdict passed and every joint is
// within --tolerance-deg, 3 otherwise, 2 on bad input.
#include "peha/api/exoskeleton.hpp"
#include "peha/models/units.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>

int main(int argc, char** argv) {
  CLI::App app{"A joint-space PD + gravity controller on a peha arm, through peha::api::Exoskeleton::control"};
  std::string config, backend = "sim:", log;
  double duration_s = 6.0, stiffness = 30.0, damping = 3.0, step_deg = 10.0, tolerance_deg = 3.0;
  int rt_priority = 80;
  app.add_option("-c,--config", config, "Arm scenario YAML (configs/right_arm.yaml)")->required()->check(CLI::ExistingFile);
  app.add_option("--backend", backend, "sim: or udp://A.B.C.D:PORT (the board)")->capture_default_str();
  app.add_option("--duration-s", duration_s, "How long to control, s")->capture_default_str()->check(CLI::Range(0.1, 3600.0));
  app.add_option("--stiffness", stiffness, "PD stiffness, Nm/rad")->capture_default_str()->check(CLI::Range(0.0, 1000.0));
  app.add_option("--damping", damping, "PD damping, Nms/rad")->capture_default_str()->check(CLI::Range(0.0, 100.0));
  app.add_option("--step-deg", step_deg, "Target step at half time, deg")->capture_default_str()->check(CLI::Range(-30.0, 30.0));
  app.add_option("--tolerance-deg", tolerance_deg, "Largest final error that passes, deg")->capture_default_str();
  app.add_option("--rt-priority", rt_priority, "On the board: SCHED_FIFO priority (0 = don't ask)")->capture_default_str();
  app.add_option("--log", log, "Per-cycle CSV to write");
  CLI11_PARSE(app, argc, argv);
  try {
    peha::api::Exoskeleton exo(config, backend);
    exo.set_realtime(rt_priority);
    const auto n = exo.joint_names().size();
    std::array<double, peha::io::kMaxJoints> target{}, last{};
    bool started = false;
    double worst_step_us = 0;
    const auto result = exo.control(
        [&](const peha::api::ArmState& s, double) {
          const auto t0 = std::chrono::steady_clock::now();
          peha::api::JointTorques tau;
          if (!started && !s.starting) {  // hold where the start-up left the arm
            for (std::size_t j = 0; j < n; ++j) target[j] = s.joints[j].angle_rad;
            started = true;
          }
          // The step as a 1 s cosine ramp from half time: a jump in the target would jump the torque and
          // let a wire go slack while the muscles' pressures follow.
          const double ramp = std::clamp(s.time_s - 0.5 * duration_s, 0.0, 1.0);
          const double step_rad = peha::models::deg_to_rad(step_deg) * 0.5 * (1.0 - std::cos(std::numbers::pi * ramp));
          for (std::size_t j = 0; j < n; ++j) {
            const auto& js = s.joints[j];
            tau.tau_Nm[j] = js.gravity_torque_Nm;
            if (started) tau.tau_Nm[j] += stiffness * (target[j] + step_rad - js.angle_rad) - damping * js.velocity_radps;
            last[j] = js.angle_rad - (target[j] + step_rad);
          }
          worst_step_us = std::max(worst_step_us, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
          return tau;
        },
        duration_s, log);
    fmt::print("pd_gravity_example on {}: {} cycles, real-time factor {:.1f}, faults {}{}; the callback's longest step {:.1f} us\n", backend,
               result.cycles, result.realtime_factor, result.faults, result.faults ? " (" + result.fault_reason + ")" : "", worst_step_us);
    fmt::print("{}", result.verdict.describe_all());
    bool on_target = started;
    for (std::size_t j = 0; j < n; ++j) {
      if (!exo.torque_controlled(j)) continue;  // a joint the scenario holds at constant pressure (a passive wrist)
      const double error_deg = peha::models::rad_to_deg(last[j]);
      on_target = on_target && std::abs(error_deg) <= tolerance_deg;
      fmt::print("  {:<8} final error {:+.2f} deg (tolerance {:.1f})\n", exo.joint_names()[j], error_deg, tolerance_deg);
    }
    fmt::print("verdict: {}\n", result.passed && on_target ? "PASSED" : "FAILED");
    return result.passed && on_target ? 0 : 3;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  }
}
