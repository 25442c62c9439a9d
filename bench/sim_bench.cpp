/// Simulated-plant benchmarks: one control period of the one-DOF rig, and a whole E1 case.
/// "realtime_factor" = simulated seconds / wall seconds (> 1: faster than real time).

#include "bench_support.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "peha/sim/mujoco_model.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

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

/// MuJoCo alone: mj_step on the same MJCF at the same timestep, substeps per control period as the
/// plant takes them, with the bias forces fed back as applied forces (the model holds its pose, as
/// the controlled plant roughly does) so the state stays in the same regime. Counter us_per_period:
/// MuJoCo's own time per 1 ms control period; BM_SimulatedRigStep / BM_SimulatedArmStep minus this
/// is peha's plant (muscles, valves, cables, motor, sensors, lifecycle) on top of it.
/// With friction_dofs, a friction-loss constraint of frictionloss_Nm on each of those dofs, as the
/// plant sets for its joints' and cables' stiction: MuJoCo's own step for the model as the plant
/// runs it (one more constraint row per driven joint).
void bare_mujoco_loop(benchmark::State& state, mjModel* m, double timestep_s, double period_s,
                      const std::vector<double>& initial_q, double frictionloss_Nm = 0.0,
                      const std::vector<int>& friction_dofs = {}) {
  m->opt.timestep = timestep_s;
  for (int dof : friction_dofs) m->dof_frictionloss[dof] += frictionloss_Nm;
  const int substeps = static_cast<int>(std::lround(period_s / timestep_s));
  sim::DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  for (int i = 0; i < m->nq && i < static_cast<int>(initial_q.size()); ++i) d->qpos[i] = initial_q[static_cast<std::size_t>(i)];
  mj_forward(m, d);
  for (auto _ : state) {
    for (int i = 0; i < substeps; ++i) {
      mju_copy(d->qfrc_applied, d->qfrc_bias, m->nv);
      mj_step(m, d);
    }
    benchmark::DoNotOptimize(d->qpos[0]);
  }
  state.counters["us_per_period"] = benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                                                       benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["realtime_factor"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * period_s, benchmark::Counter::kIsRate);
}

void BM_BareMujocoRigStep(benchmark::State& state) {
  const sim::OneDofRigParams params = heavy_plant_params();
  sim::ModelPtr model = sim::load_mjcf(params.model_file);
  bare_mujoco_loop(state, model.get(), params.timestep_s, params.control_period_s, {params.initial_angle_rad});
}
BENCHMARK(BM_BareMujocoRigStep)->UseRealTime();

/// The same, with a friction-loss constraint on the joint as the plant sets for the cables'
/// stiction (5 Nm): MuJoCo's own step for the model as the plant runs it (one more constraint row
/// for its solver).
void BM_BareMujocoRigStepWithFriction(benchmark::State& state) {
  const sim::OneDofRigParams params = heavy_plant_params();
  sim::ModelPtr model = sim::load_mjcf(params.model_file);
  const int dof = model->jnt_dofadr[sim::require_id(model.get(), mjOBJ_JOINT, "joint", params.model_file.string())];
  bare_mujoco_loop(state, model.get(), params.timestep_s, params.control_period_s, {params.initial_angle_rad}, 5.0, {dof});
}
BENCHMARK(BM_BareMujocoRigStepWithFriction)->UseRealTime();

/// MuJoCo alone on an arm scenario's generated MJCF (configs/<file>); with frictionloss_Nm > 0 a
/// friction-loss row on each driven joint, as the plant puts there.
void bare_arm_loop(benchmark::State& state, const char* file, double frictionloss_Nm = 0.0) {
  const experiments::ArmScenario s =
      experiments::read_arm_scenario(config::Document::load_file(std::string(PEHA_SOURCE_DIR "/configs/") + file));
  sim::ModelPtr model = sim::load_arm_mjcf(sim::arm_mjcf(s.plant.model, s.plant.mjcf));
  std::vector<int> driven_dofs;
  for (const std::string& name : s.plant.actuated) {
    driven_dofs.push_back(model->jnt_dofadr[sim::require_id(model.get(), mjOBJ_JOINT, name, file)]);
  }
  bare_mujoco_loop(state, model.get(), s.plant.timestep_s, s.plant.control_period_s, s.plant.initial_q_rad,
                   frictionloss_Nm, driven_dofs);
}

void BM_BareMujocoArmStep(benchmark::State& state) { bare_arm_loop(state, "right_arm.yaml"); }
BENCHMARK(BM_BareMujocoArmStep)->UseRealTime();

/// The same with a friction-loss row on each driven joint (5 Nm), as the plant runs the model.
void BM_BareMujocoArmStepWithFriction(benchmark::State& state) { bare_arm_loop(state, "right_arm.yaml", 5.0); }
BENCHMARK(BM_BareMujocoArmStepWithFriction)->UseRealTime();

void BM_BareMujocoUpperBodyStep(benchmark::State& state) { bare_arm_loop(state, "upper_body.yaml"); }
BENCHMARK(BM_BareMujocoUpperBodyStep)->UseRealTime();

}  // namespace
}  // namespace peha::bench
