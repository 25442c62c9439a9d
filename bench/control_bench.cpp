/// Host-side control benchmarks: the Tendon-spring model, one allocation step and the full control
/// step (controller + limits layer). "us_per_step" is in microseconds (the console appends "s" to
/// every inverted rate); the control period is 1000 us.

#include "bench_support.hpp"

#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/spgp.hpp"

#include "peha/control/allocation.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/models/tendon_spring.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "peha/safety/limits.hpp"

#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <memory>
#include <cstddef>
#include <optional>
#include <random>

namespace peha::bench {
namespace {

constexpr std::size_t kInputs = 1024;  // power of two: the index wraps with a mask
static_assert((kInputs & (kInputs - 1)) == 0);

// Per-step time as a counter: seconds / (iterations * 1e-6) = microseconds per iteration (CPU time,
// like the Time/CPU columns of these single-threaded micro-benchmarks).
benchmark::Counter us_per_iteration(benchmark::State& state) {
  return benchmark::Counter(static_cast<double>(state.iterations()) * 1e-6,
                            benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

struct ModelInput {
  double value;  // force in N (inverse) or pressure in Pa (forward)
  double eps;    // rigid-wire contraction
};

// Agonist (DMSP-40) inputs over the rig's working range: +-45 deg around a contraction of 0.10.
std::array<ModelInput, kInputs> model_inputs(double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> value(lo, hi);
  std::uniform_real_distribution<double> eps(0.03, 0.17);
  std::array<ModelInput, kInputs> in{};
  for (ModelInput& i : in) i = {value(rng), eps(rng)};
  return in;
}

void BM_TendonSpringInverse(benchmark::State& state) {
  const models::TendonSpringParams p = e1_scenario().controller.joint.agonist.pam;
  const auto in = model_inputs(20.0, 1500.0, 1);  // force in N
  std::size_t k = 0;
  for (auto _ : state) {
    const ModelInput& i = in[k++ & (kInputs - 1)];
    models::InverseResult r = models::inverse_pressure(p, i.value, i.eps, 0.8e6);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TendonSpringInverse);

void BM_TendonSpringForward(benchmark::State& state) {
  const models::TendonSpringParams p = e1_scenario().controller.joint.agonist.pam;
  const auto in = model_inputs(0.0, 0.8e6, 2);  // pressure in Pa
  std::size_t k = 0;
  for (auto _ : state) {
    const ModelInput& i = in[k++ & (kInputs - 1)];
    double f = models::forward_force_N(p, i.value, i.eps);
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TendonSpringForward);

// One allocation step on the inputs the controller really produced in the recorded E1 run.
void BM_Allocate(benchmark::State& state) {
  const control::OneDofControllerModel m = heavy_controller_model();
  const std::vector<control::AllocationInput>& in = e1_recording().allocation;
  control::AllocationData data;
  control::AllocationOutput out;
  std::size_t k = 0;
  for (auto _ : state) {
    control::allocate(m.joint, m.allocation, data, in[k], out);
    benchmark::DoNotOptimize(out);
    if (++k == in.size()) k = 0;  // a small torque step at the wrap; harmless for the timing
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_step"] = us_per_iteration(state);
}
BENCHMARK(BM_Allocate);

/// The E1 controller `m` on the recorded E1 states, with the limits stage; the controller and limits
/// restart (untimed) at the recording's end. Counter filter_updates > 0: the creep estimator ran its filter.
void run_control_step_bench(benchmark::State& state, const control::OneDofControllerModel& m) {
  const experiments::E1Scenario& s = e1_scenario();
  const std::vector<io::SensorState>& states = e1_recording().states;
  std::optional<control::OneDofGravityController> controller(std::in_place, m);
  safety::LimitsData limits;
  io::Command command;
  std::size_t k = 0, updates = 0;
  for (auto _ : state) {
    const io::SensorState& x = states[k];
    controller->update(x, command);
    std::uint32_t flags = safety::apply_limits(s.limits, {&m.joint}, limits, x, command);
    benchmark::DoNotOptimize(flags);
    benchmark::DoNotOptimize(command);
    if (++k == states.size()) {
      state.PauseTiming();
      updates += static_cast<std::size_t>(controller->diagnostics().creep.muscle[0].updates);
      k = 0;
      controller.emplace(m);
      limits = safety::LimitsData{};
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_step"] = us_per_iteration(state);
  state.counters["filter_updates"] = static_cast<double>(updates);
}

// The full host control step: OneDofGravityController::update + safety::apply_limits, on the sensor
// states recorded from the closed-loop simulated rig (5.0 kg E1 case, 24 s). At the end of the
// recording the controller and limits restart (untimed), so time stamps stay monotonic.
void BM_ControlStep(benchmark::State& state) { run_control_step_bench(state, heavy_controller_model()); }
BENCHMARK(BM_ControlStep);

// The same full control step with the wire-creep estimator off (/0) and on (/1), in one run on the
// same recorded states (docs/creep.md, "Cost"): the estimator's share of the step is the difference.
// The estimator's default parameters (E1's nominal model: no residual).
void BM_ControlStepCreepEstimator(benchmark::State& state) {
  control::OneDofControllerModel m = heavy_controller_model();
  m.creep.enabled = state.range(0) != 0;
  run_control_step_bench(state, m);
}
BENCHMARK(BM_ControlStepCreepEstimator)->Arg(0)->Arg(1);

/// The E1 controller's muscles with an SPGP pressure residual like a calibration's (bench_support).
control::OneDofControllerModel controller_with_spgp() {
  control::OneDofControllerModel m = heavy_controller_model();
  m.joint.agonist.residual = synthetic_spgp_residual();
  m.joint.antagonist.residual = synthetic_spgp_residual();
  return m;
}

// The control step of a calibrated controller (SPGP residual on both muscles) with the estimator off
// (/0) and on (/1) as configs/e1_creep.yaml runs it (residual at the corrected contraction: one more
// SPGP evaluation per accepted sample and muscle). The recorded states come from the nominal
// controller, so the valve-settled gate is opened (settle tolerance 1 MPa): every static sample is
// inverted, the estimator's most expensive case.
void BM_ControlStepCreepEstimatorSpgp(benchmark::State& state) {
  control::OneDofControllerModel m = controller_with_spgp();
  m.creep.enabled = state.range(0) != 0;
  m.creep.residual_at_corrected_contraction = true;
  m.creep.settle_tolerance_Pa = 1e6;
  run_control_step_bench(state, m);
}
BENCHMARK(BM_ControlStepCreepEstimatorSpgp)->Arg(0)->Arg(1);

// The supervisor's plausibility stage per control step, as LimitedBackend runs it (check the sample,
// check the command, shape it to the safe state, note what was sent), on: the recorded closed-loop
// samples and commands of the 5.0 kg E1 run from 2.5 s on (the shipped controller's start-up tare
// before). The stage is restarted (untimed) at the end of the recording. Goal: < 200 ns per step.
// `descending`: the same samples with the agonist's load cell stuck at 500 N, so loadcell_stuck latches
// after 5 cycles and every later step runs the descend governor (two pressure-model inversions).
void supervisor_step(benchmark::State& state, bool descending) {
  const experiments::E1Scenario& s = e1_scenario();
  const E1Recording& rec = e1_recording();
  std::vector<io::SensorState> samples = rec.states;
  if (descending) {
    for (io::SensorState& x : samples) x.joints[0].agonist_loadcell_N = 500.0;
  }
  safety::MonitorParams params = s.limits.monitor;
  // The recording does not follow the governor's commands (open loop): the checks that compare the
  // pressures (or the motor monitor) with the commands would latch, which is not what is timed here.
  safety::CheckOverrides overrides;
  if (descending) overrides.unchecked = safety::kFaultPressureHigh | safety::kFaultPressureLow | safety::kFaultSupplyLoss | safety::kFaultMotorDisagrees;
  std::optional<safety::FaultMonitor> monitor(std::in_place, params, s.period_s, overrides);
  std::array<const models::JointModel*, io::kMaxJoints> joints{};
  joints[0] = &s.controller.joint;
  std::array<double, io::kMaxJoints> min_angle{}, max_angle{};
  min_angle[0] = s.limits.joints[0].min_angle_rad;
  max_angle[0] = s.limits.joints[0].max_angle_rad;
  std::size_t first = 0;
  while (first + 1 < samples.size() && samples[first].time_s < 2.5) ++first;
  std::size_t k = first;
  io::Command command;
  double descend_steps = 0;
  for (auto _ : state) {
    const io::SensorState& x = samples[k];
    io::copy_used(command, rec.commands[k]);
    monitor->check_sample(x, joints, min_angle, max_angle, true);
    monitor->check_command(command, x.time_s);
    monitor->shape(command);
    monitor->sent(command);
    descend_steps += monitor->action() == safety::SafeAction::kDescend ? 1.0 : 0.0;
    benchmark::DoNotOptimize(command);
    if (++k == samples.size()) {
      state.PauseTiming();
      k = first;
      monitor.emplace(params, s.period_s, overrides);
      state.ResumeTiming();
    }
  }
  state.counters["faults_latched"] = static_cast<double>(monitor->count());
  state.counters["descend_share"] = descend_steps / static_cast<double>(state.iterations());  // steps timed in the descend state
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_step"] = us_per_iteration(state);
}
void BM_SupervisorStep(benchmark::State& state) { supervisor_step(state, false); }
BENCHMARK(BM_SupervisorStep);
void BM_SupervisorStepDescending(benchmark::State& state) { supervisor_step(state, true); }
BENCHMARK(BM_SupervisorStepDescending);

}  // namespace
}  // namespace peha::bench
