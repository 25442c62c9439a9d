/// Simulated-plant benchmarks: one control period of the one-DOF rig, and a whole E1 case.
/// "realtime_factor" = simulated seconds / wall seconds (> 1: faster than real time).

#include "bench_support.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <benchmark/benchmark.h>

#include <cstddef>
#include <optional>

namespace peha::bench {
namespace {

// One control period (1 ms, 2 MuJoCo substeps of 0.5 ms): OneDofRigBackend::write + read, replaying
// the commands the closed loop sent in the recorded 5.0 kg E1 run. The plant is deterministic, so a
// fresh plant fed those commands follows the recorded trajectory (pushes, releases, holds). At the
// end of the recording the plant is rebuilt (untimed). Wall time, since the factor is against it.
void BM_SimulatedRigStep(benchmark::State& state) {
  const sim::OneDofRigParams params = heavy_plant_params();
  const std::vector<io::Command>& commands = e1_recording().commands;
  const std::size_t steps = commands.size() - 1;  // the last command is never written
  std::optional<sim::OneDofRigBackend> plant(std::in_place, params);
  plant->activate();
  io::SensorState sensors;
  plant->read(sensors);
  std::size_t k = 0;
  for (auto _ : state) {
    plant->write(commands[k]);
    plant->read(sensors);
    benchmark::DoNotOptimize(sensors);
    if (++k == steps) {
      state.PauseTiming();
      k = 0;
      plant.emplace(params);
      plant->activate();
      plant->read(sensors);
      state.ResumeTiming();
    }
  }
  const double period_s = e1_scenario().period_s;
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_step"] = benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["realtime_factor"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * period_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulatedRigStep)->UseRealTime();

// One whole E1 case (5.0 kg, 24 s simulated): plant construction, closed loop, release analysis.
void BM_E1CaseFull(benchmark::State& state) {
  const experiments::E1Scenario& s = e1_scenario();
  const experiments::E1Case& c = e1_heavy_case();
  double internal_rtf = 0;
  for (auto _ : state) {
    experiments::E1Result r = experiments::run_e1_case(s, c, nullptr);
    internal_rtf += r.realtime_factor;
    benchmark::DoNotOptimize(r);
  }
  state.counters["realtime_factor"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * s.duration_s, benchmark::Counter::kIsRate);
  // run_e1_case's own measure (closed loop only, without construction and analysis), mean.
  state.counters["loop_rtf"] = benchmark::Counter(internal_rtf, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_E1CaseFull)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

}  // namespace
}  // namespace peha::bench
