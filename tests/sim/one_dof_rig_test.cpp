#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace peha::sim {
namespace {

OneDofRigParams rig() {
  return experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml")).plant;
}

// At rest the wire tension is the muscle law at the muscle's own contraction, which includes the
// wire's stretch: T = F(P, eps + (slack + creep + T/k_wire)/L0), solved to 1e-6 relative.
TEST(SimulatedRig, WireTensionSolvesTheMuscleWireEquilibrium) {
  OneDofRigParams p = rig();
  p.payload_kg = 2.5;
  p.finger.pushes = {{"hold", 0.0, 10.0, 10.0, 0.0, true}};
  OneDofRigBackend plant(p);
  plant.activate();
  io::Command c;
  c.joint_count = 1;
  c.joints[0] = {0.12e6, 0.21e6, 0.0};  // about what holds 2.5 kg (see E1), the hand does the rest
  for (int k = 0; k < 3000; ++k) plant.write(c);
  const OneDofRigTruth& t = plant.truth();
  ASSERT_LT(std::abs(t.velocity_radps), 1e-3);
  const double r0 = p.joint.pulley_radius_m;
  for (int i = 0; i < 2; ++i) {
    const MusclePlantParams& m = i == 0 ? p.joint.agonist : p.joint.antagonist;
    const int side = i == 0 ? +1 : -1;
    const double eps = m.contraction_at_zero_angle + side * r0 * t.angle_rad / m.rest_length_m;
    const double T = t.muscle_force_N[i];
    const double u = eps + (m.cable.initial_slack_m + t.creep_m[i] + T / m.cable.wire_stiffness_N_per_m) / m.rest_length_m;
    EXPECT_NEAR(t.muscle_contraction[i], u, 1e-7);  // solved at the angle before the last MuJoCo step
    EXPECT_NEAR(T, static_force_N(m.law, t.pressure_Pa[i], u), 1e-3 * T + 0.05) << i;  // hysteresis ~0 at rest
    EXPECT_GT(T, 0.0);
  }
}

// The load cells read the muscle force with the configured noise and 16-bit resolution: over 1 s at
// rest the mean is within 0.2 N and the spread within 50 % of the configured 1 N.
TEST(SimulatedRig, LoadCellsReadMuscleForceWithConfiguredNoise) {
  OneDofRigParams p = rig();
  p.finger.pushes = {{"hold", 0.0, 10.0, 10.0, 0.0, true}};
  OneDofRigBackend plant(p);
  plant.activate();
  io::Command c;
  c.joint_count = 1;
  c.joints[0] = {0.25e6, 0.3e6, 0.0};
  for (int k = 0; k < 2000; ++k) plant.write(c);
  io::SensorState s;
  double sum = 0, sum2 = 0;
  const int n = 1000;
  for (int k = 0; k < n; ++k) {
    plant.write(c);
    plant.read(s);
    const double e = s.joints[0].agonist_loadcell_N - plant.truth().muscle_force_N[0];
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / n;
  const double sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_LT(std::abs(mean), 0.2);
  EXPECT_NEAR(sd, p.joint.agonist.loadcell_noise_N, 0.5 * p.joint.agonist.loadcell_noise_N);
  // Encoder: the measured angle is the true one floored to 2 pi / 70000.
  const double step = 2.0 * M_PI / p.encoder_counts_per_rev;
  EXPECT_LE(plant.truth().angle_rad - s.joints[0].angle_rad, step);
  EXPECT_GE(plant.truth().angle_rad - s.joints[0].angle_rad, 0.0);
}

}  // namespace
}  // namespace peha::sim
