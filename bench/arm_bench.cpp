// The right arm's control step (J^T G over 5 joints and 9 bodies + three allocations + limits) and
// one control period of the simulated arm (MuJoCo + three PehaJointPlants), on states recorded from
// the simulated arm holding a loaded posture.
#include "peha/experiments/e3_postures/postures.hpp"

#include <benchmark/benchmark.h>

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
    sim::RightArmBackend plant(scenario().plant);
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

void BM_SimulatedArmStep(benchmark::State& state) {
  sim::RightArmBackend plant(scenario().plant);
  plant.activate();
  control::ArmController controller(scenario().controller);
  safety::LimitsData limits;
  io::SensorState s;
  io::Command command;
  for (auto _ : state) {
    plant.read(s);
    controller.update(s, command);
    safety::apply_limits(scenario().limits, experiments::arm_joint_models(scenario().controller), limits, s, command);
    plant.write(command);
  }
  state.counters["realtime_factor"] = benchmark::Counter(static_cast<double>(state.iterations()) * scenario().period_s,
                                                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulatedArmStep)->UseRealTime();

}  // namespace
