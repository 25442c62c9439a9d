// The right arm's control step (J^T G over 5 joints and 9 bodies + three allocations + limits) and
// one control period of the simulated arm (MuJoCo + three PehaJointPlants), on states recorded from
// the simulated arm holding a loaded posture.
#include "peha/api/exoskeleton.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/spgp.hpp"
#include "peha/experiments/e3_postures/postures.hpp"

#include "bench_support.hpp"

#include "../tests/support/alloc_counter.hpp"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

namespace {

using namespace peha;

const experiments::ArmScenario& scenario() {
  static const experiments::ArmScenario s =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml"));
  return s;
}

/// 2 s of sensor states from the simulated arm under its own controller.
const std::vector<io::SensorState>& recorded_states() {
  static const std::vector<io::SensorState> states = [] {
    sim::ArmBackend plant(scenario().plant);
    plant.activate();
    control::ArmController controller(scenario().controller);
    safety::LimitsData limits;
    std::vector<io::SensorState> out(2000);
    io::Command command;
    for (auto& s : out) {
      plant.read(s);
      controller.update(s, command);
      safety::apply_limits(scenario().limits, experiments::arm_joint_models(scenario().controller), limits, s, command);
      plant.write(command);
    }
    return out;
  }();
  return states;
}

void BM_ArmControlStep(benchmark::State& state) {
  const auto& states = recorded_states();
  control::ArmController controller(scenario().controller);
  safety::LimitsData limits;
  io::Command command;
  std::size_t k = 0;
  for (auto _ : state) {
    controller.update(states[k], command);
    safety::apply_limits(scenario().limits, experiments::arm_joint_models(scenario().controller), limits, states[k], command);
    benchmark::DoNotOptimize(command);
    if (++k == states.size()) {  // restart the sequence so time stamps keep increasing
      state.PauseTiming();
      controller = control::ArmController(scenario().controller);
      limits = safety::LimitsData{};
      k = 0;
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ArmControlStep);

/// One control period of a simulated arm scenario under its own controller and limits.
void simulated_step(benchmark::State& state, const experiments::ArmScenario& sc) {
  sim::ArmBackend plant(sc.plant);
  plant.activate();
  control::ArmController controller(sc.controller);
  const safety::JointModels joints = experiments::arm_joint_models(sc.controller);
  safety::LimitsData limits;
  io::SensorState s;
  io::Command command;
  for (auto _ : state) {
    plant.read(s);
    controller.update(s, command);
    safety::apply_limits(sc.limits, joints, limits, s, command);
    plant.write(command);
  }
  state.counters["realtime_factor"] = benchmark::Counter(static_cast<double>(state.iterations()) * sc.period_s,
                                                         benchmark::Counter::kIsRate);
}

void BM_SimulatedArmStep(benchmark::State& state) { simulated_step(state, scenario()); }
BENCHMARK(BM_SimulatedArmStep)->UseRealTime();

/// A user's controller through peha::api::Exoskeleton::control on the simulated arm (a gravity
/// callback): per cycle the same plant, controller and limits as BM_SimulatedArmStep, plus what the
/// API adds around the callback (the plausibility monitor, the lifecycle supervisor, the loop, the
/// state it builds). Time per item = one control period; compare with BM_SimulatedArmStep.
void BM_UserControllerArmCycle(benchmark::State& state) {
  api::Exoskeleton exo(PEHA_SOURCE_DIR "/configs/right_arm.yaml");
  std::uint64_t cycles = 0;
  for (auto _ : state) {
    const api::ControlResult r = exo.control(
        [](const api::ArmState& s, double) {
          api::JointTorques tau;
          for (int j = 0; j < s.joint_count; ++j) tau.tau_Nm[static_cast<std::size_t>(j)] = s.joints[static_cast<std::size_t>(j)].gravity_torque_Nm;
          return tau;
        },
        2.0);
    cycles += r.cycles;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(cycles));
  state.counters["us_per_cycle"] = benchmark::Counter(static_cast<double>(cycles) * 1e-6, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_UserControllerArmCycle)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The upper body (configs/upper_body.yaml): both arms, 8 driven joints, 12 model joints (issue 14's
/// simulation real-time factor).
void BM_SimulatedUpperBodyStep(benchmark::State& state) {
  static const experiments::ArmScenario upper_body =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  simulated_step(state, upper_body);
}
BENCHMARK(BM_SimulatedUpperBodyStep)->UseRealTime();

/// The arm controller's model with the SPGP residual on all six muscles (3 joints x 2).
const control::ArmControllerModel& controller_with_spgp() {
  static const control::ArmControllerModel model = [] {
    control::ArmControllerModel m = scenario().controller;
    const auto residual = bench::synthetic_spgp_residual();
    for (control::ArmActuatedJoint& j : m.joints) {
      j.actuator.agonist.residual = residual;
      j.actuator.antagonist.residual = residual;
    }
    return m;
  }();
  return model;
}

/// The full arm step as the calibrated controller runs it: J^T G over the arm, per joint the
/// allocation (Bowden compensation, closed-form inverse + SPGP residual per muscle) and the limits
/// stage (the pressure band again through inverse + SPGP), on the recorded states. Each step is
/// timed on its own (steady_clock, ~20 ns of the figure is the clock itself); counters: median,
/// p99, p99.9 and max in ns, heap allocations per step (operator new, counted over all steps),
/// band_reuse: the fraction of the six pressure bands per step the limits stage reused (the joint
/// had not moved by an encoder count). Argument 1 forgets the bands before every step (untimed):
/// every band computed, the step of an arm that moves every period.
void BM_ArmControlStepWithSpgp(benchmark::State& state) {
  const bool forget_bands = state.range(0) != 0;
  const auto& states = recorded_states();
  const control::ArmControllerModel& model = controller_with_spgp();
  const safety::JointModels joints = experiments::arm_joint_models(model);
  constexpr std::size_t kSteps = 200000;
  std::vector<double> ns(kSteps);
  std::size_t allocations = 0;
  std::uint64_t band_evaluations = 0;
  for (auto _ : state) {
    control::ArmController controller(model);
    safety::LimitsData limits;
    io::Command command;
    std::size_t k = 0;
    for (std::size_t i = 0; i < kSteps; ++i) {
      if (k == states.size()) {  // restart the sequence so time stamps keep increasing
        controller = control::ArmController(model);
        band_evaluations += limits.band_evaluations;
        limits = safety::LimitsData{};
        k = 0;
      }
      if (forget_bands) limits.bands = {};
      const std::size_t before = testing::allocation_count();
      const auto t0 = std::chrono::steady_clock::now();
      controller.update(states[k], command);
      safety::apply_limits(scenario().limits, joints, limits, states[k], command);
      const auto t1 = std::chrono::steady_clock::now();
      allocations += testing::allocation_count() - before;
      benchmark::DoNotOptimize(command);
      ns[i] = std::chrono::duration<double, std::nano>(t1 - t0).count();
      ++k;
    }
    band_evaluations += limits.band_evaluations;
  }
  std::sort(ns.begin(), ns.end());
  const auto quantile = [&](double q) { return ns[static_cast<std::size_t>(q * static_cast<double>(kSteps - 1))]; };
  state.counters["median_ns"] = quantile(0.5);
  state.counters["p99_ns"] = quantile(0.99);
  state.counters["p999_ns"] = quantile(0.999);
  state.counters["max_ns"] = ns.back();
  state.counters["allocs_per_step"] = static_cast<double>(allocations) / static_cast<double>(kSteps);
  const double bands = 2.0 * static_cast<double>(scenario().limits.joint_count) * static_cast<double>(kSteps);
  state.counters["band_reuse"] = 1.0 - static_cast<double>(band_evaluations) / bands;
}
BENCHMARK(BM_ArmControlStepWithSpgp)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);

/// A chain of `n` PEHA joints (each the right arm's elbow: DMSP-40/DMSP-10 pair, motor, Bowden
/// cables; each link 1.2 kg at 0.15 m), its controller and limits, and 2000 sensor states of it
/// moving slowly: the control step's cost against the number of joints (issue 14: it must grow
/// linearly). Same work per joint as the arm: J^T G, allocation, limits.
struct ChainSetup {
  control::ArmControllerModel controller;
  safety::LimitsModel limits;
  std::vector<io::SensorState> states;
};

ChainSetup chain_setup(int n) {
  ChainSetup c;
  const experiments::ArmScenario& arm = scenario();
  for (int i = 0; i < n; ++i) {
    models::ArmJoint j{fmt::format("J{}", i), i == 0 ? Eigen::Vector3d(0, 0, 1.4) : Eigen::Vector3d(0.3, 0, 0),
                       i % 3 == 2 ? Eigen::Vector3d(0, 0, 1) : Eigen::Vector3d(0, -1, 0), true};
    c.controller.arm.joints.push_back(j);
    c.controller.arm.bodies.push_back({fmt::format("link{}", i), i, 1.2, Eigen::Vector3d(0.15, 0, 0),
                                       Eigen::Vector3d(0.002, 0.01, 0.01).asDiagonal()});
    control::ArmActuatedJoint a = arm.controller.joints[1];  // the elbow's actuator model
    a.model_joint = i;
    c.controller.joints.push_back(a);
    c.limits.joints[static_cast<std::size_t>(i)] = arm.limits.joints[1];
  }
  c.controller.allocation = arm.controller.allocation;
  c.controller.velocity_cutoff_Hz = arm.controller.velocity_cutoff_Hz;
  c.limits.joint_count = n;
  c.limits.period_s = arm.limits.period_s;
  c.limits.monitor = arm.limits.monitor;
  c.states.resize(2000);
  for (std::size_t k = 0; k < c.states.size(); ++k) {
    io::SensorState& st = c.states[k];
    st.time_s = 1e-3 * static_cast<double>(k);
    st.sequence = k;
    st.joint_count = n;
    for (int i = 0; i < n; ++i) {
      io::JointSensors& js = st.joints[static_cast<std::size_t>(i)];
      js.angle_rad = 1.0 + 0.3 * std::sin(0.5 * st.time_s + i);
      js.agonist_loadcell_N = 300 + 50 * std::sin(st.time_s + i);
      js.antagonist_loadcell_N = 60;
      js.agonist_pressure_Pa = 3e5;
      js.antagonist_pressure_Pa = 2e5;
    }
  }
  return c;
}

void BM_ArmControlStepJoints(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const ChainSetup c = chain_setup(n);
  control::ArmController controller(c.controller);
  safety::LimitsData limits;
  const safety::JointModels models = experiments::arm_joint_models(c.controller);
  io::Command command;
  std::size_t k = 0;
  for (auto _ : state) {
    controller.update(c.states[k], command);
    safety::apply_limits(c.limits, models, limits, c.states[k], command);
    benchmark::DoNotOptimize(command);
    if (++k == c.states.size()) {
      state.PauseTiming();
      controller = control::ArmController(c.controller);
      limits = safety::LimitsData{};
      k = 0;
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["joints"] = n;
  state.counters["ns_per_joint"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ArmControlStepJoints)->Arg(1)->Arg(3)->Arg(8)->Arg(16);

}  // namespace
