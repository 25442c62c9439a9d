// The control step allocates nothing (STYLE.md principle 3): the controller's update and the
// limits layer run 10^4 cycles on the simulated rig without a single heap allocation.
#include "peha/safety/limited_backend.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/safety/limits.hpp"

#include "../support/alloc_counter.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

namespace peha {
namespace {

/// Allocations of `steps` control cycles as every experiment runs them: read and write through the
/// limits stage at the boundary, the controller's update between.
std::size_t closed_loop_allocations(io::Backend& plant, const experiments::E1Scenario& scenario,
                                    control::OneDofGravityController& controller, int steps) {
  safety::LimitedBackend limited(plant, scenario.limits, {&scenario.controller.joint});
  limited.activate();
  io::SensorState state;
  io::Command command;
  std::size_t allocations = 0;
  for (int k = 0; k < steps; ++k) {
    allocations += testing::allocations_during([&] {
      limited.read(state);
      controller.update(state, command);
      limited.write(command);
    });
  }
  return allocations;
}

TEST(ControlStep, AllocatesNothing) {
  const experiments::E1Scenario scenario =
      peha::test_support::shipped_e1();
  sim::OneDofRigParams plant_params = scenario.plant;
  sim::OneDofRigBackend plant(plant_params);
  control::OneDofGravityController controller(scenario.controller);
  EXPECT_EQ(closed_loop_allocations(plant, scenario, controller, 10000), 0u);
}

// The new paths of the step allocate nothing either: the start-up tare (vent, average), and a load
// cell the controller stops trusting (an antagonist cell 300 N high, beyond what the tare believes,
// with twice the gain: trim frozen, motor on the model's force). The phase and the flag show that
// both paths really ran.
TEST(ControlStep, AllocatesNothingWhileTaringOrDistrustingALoadcell) {
  experiments::E1Scenario scenario =
      peha::test_support::shipped_e1();
  scenario.controller.allocation.loadcell_check.tare_s = 0.3;
  scenario.plant.joint.antagonist.loadcell_gain = 2.0;
  scenario.plant.joint.antagonist.loadcell_offset_N = 300.0;
  sim::OneDofRigBackend plant(scenario.plant);
  control::OneDofGravityController controller(scenario.controller);
  safety::LimitedBackend limited(plant, scenario.limits, {&scenario.controller.joint});
  limited.activate();
  io::SensorState state;
  io::Command command;
  std::size_t control_allocations = 0;
  bool tared = false, distrusted = false;
  for (int k = 0; k < 3000; ++k) {
    control_allocations += testing::allocations_during([&] {
      limited.read(state);
      controller.update(state, command);
      limited.write(command);
    });
    tared |= controller.diagnostics().phase == control::StartupPhase::kTaring;
    distrusted |= (controller.diagnostics().allocation.flags & control::kLoadcellDisagrees) != 0;
  }
  EXPECT_TRUE(tared);
  EXPECT_TRUE(distrusted);
  EXPECT_EQ(control_allocations, 0u);
}

// The creep estimator runs inside the step: gating, the model's inversion, the block average, the
// filter update, the correction and the alerts allocate nothing. The plant's wires creep fast so that
// the estimator passes its reference, updates and raises its recalibrate alert within the run (the
// start-up hold, then the link left alone until the first push at 6 s).
TEST(ControlStep, AllocatesNothingWithTheCreepEstimator) {
  experiments::E1Scenario scenario =
      peha::test_support::shipped_e1();
  scenario.controller.creep.enabled = true;
  scenario.controller.creep.reference_s = 0.5;
  scenario.controller.creep.reference_delay_s = 1.0;
  scenario.controller.creep.alert_m = 0.00005;
  scenario.controller.creep.alert_sigmas = 0.0;
  for (auto* m : {&scenario.plant.joint.agonist, &scenario.plant.joint.antagonist}) {
    m->cable.creep_m_per_N_s = 5e-7;  // ~0.2 mm/s: fast, yet the link stays within the gate's speed
    m->cable.max_creep_m = 0.004;
  }
  sim::OneDofRigBackend plant(scenario.plant);
  control::OneDofGravityController controller(scenario.controller);
  const std::size_t control_allocations = closed_loop_allocations(plant, scenario, controller, 8000);
  const control::CreepEstimatorData& d = controller.diagnostics().creep;
  EXPECT_TRUE(d.muscle[0].referenced);
  EXPECT_GT(d.muscle[0].updates, 10);
  EXPECT_NE(d.alerts & control::kCreepRecalibrateAgonist, 0u);
  EXPECT_EQ(control_allocations, 0u);
}

// The simulated plant steps without allocating too (MuJoCo works in its preallocated arena).
TEST(SimulatedRig, StepsWithoutAllocating) {
  const experiments::E1Scenario scenario =
      peha::test_support::shipped_e1();
  sim::OneDofRigBackend plant(scenario.plant);
  plant.activate();
  io::SensorState state;
  io::Command command;
  command.joint_count = 1;
  command.joints[0] = {0.2e6, 0.3e6, 0.5};
  const std::size_t n = testing::allocations_during([&] {
    for (int k = 0; k < 5000; ++k) {
      plant.read(state);
      plant.write(command);
    }
  });
  EXPECT_EQ(n, 0u);
}

}  // namespace
}  // namespace peha
