#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/sim/one_dof_rig.hpp"
#include "../support/replaced.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

namespace peha::sim {
namespace {

OneDofRigParams rig() {
  return peha::test_support::shipped_e1().plant;
}

std::string e1_text() {
  std::ifstream in(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The E1 scenario with `from` replaced by `to` (once), read as if it were the shipped file.
OneDofRigParams rig_with(const std::string& from, const std::string& to) {
  std::string text = testing::replaced(e1_text(), from, to);
  // The file's relative paths made absolute: a string document resolves them against ".".
  for (const auto& [relative, absolute] : {std::pair<std::string, std::string>{"law: plant/", "law: " PEHA_SOURCE_DIR "/configs/plant/"},
                                           {"model: ../models/", "model: " PEHA_SOURCE_DIR "/models/"}}) {
    for (auto at = text.find(relative); at != std::string::npos; at = text.find(relative, at + absolute.size())) {
      text.replace(at, relative.size(), absolute);
    }
  }
  return experiments::read_e1(config::Document::load_string(text, "e1_one_dof.yaml")).plant;
}

/// The finger force (N, along the link's normal) a hand needs to hold the vented rig still at
/// 0 rad, averaged over the last 0.5 s of 3 s: the weight of link and payload at the finger's lever.
double holding_force_N(OneDofRigParams p) {
  p.initial_angle_rad = 0.0;
  p.joint.agonist.initial_pressure_Pa = p.joint.antagonist.initial_pressure_Pa = 0.0;
  p.finger.pushes = {{"hold", 0.0, 10.0, 10.0, 0.0, true}};
  OneDofRigBackend plant(p);
  plant.activate();
  io::Command c;
  c.joint_count = 1;
  c.joints[0] = {0.0, 0.0, 0.0};  // vented: the cables carry (almost) nothing, the hand holds the link
  double sum = 0;
  for (int k = 0; k < 3000; ++k) {
    plant.write(c);
    if (k >= 2500) sum += plant.truth().finger_force_N;
  }
  return sum / 500.0;
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

// The plant-only knobs are optional keys with neutral defaults: the shipped E1 file has none of
// them, so it reads offset 0, gain 1, no supply cap and no unknown payload; written out, they are
// read; out of range, they are rejected.
TEST(SimulatedRig, PlantOnlyKnobsAreOptionalWithNeutralDefaults) {
  const OneDofRigParams shipped = rig();
  EXPECT_EQ(shipped.joint.agonist.loadcell_offset_N, 0.0);
  EXPECT_EQ(shipped.joint.antagonist.loadcell_gain, 1.0);
  EXPECT_EQ(shipped.joint.supply_cap_Pa, std::numeric_limits<double>::infinity());
  EXPECT_EQ(shipped.unknown_payload_kg, 0.0);

  const OneDofRigParams p = rig_with("loadcell: {noise_N: 0.5, range_N: 1000.0}",
                                     "loadcell: {noise_N: 0.5, range_N: 1000.0, offset_N: -45.0, gain: 1.08}");
  EXPECT_EQ(p.joint.antagonist.loadcell_offset_N, -45.0);
  EXPECT_EQ(p.joint.antagonist.loadcell_gain, 1.08);
  EXPECT_EQ(p.joint.agonist.loadcell_offset_N, 0.0);
  EXPECT_EQ(rig_with("  timestep_s: 0.0005\n", "  timestep_s: 0.0005\n  supply_cap_MPa: 0.5\n").joint.supply_cap_Pa, 0.5e6);
  EXPECT_EQ(rig_with("  timestep_s: 0.0005\n", "  timestep_s: 0.0005\n  unknown_payload_kg: -0.5\n").unknown_payload_kg, -0.5);
  EXPECT_THROW(rig_with("  timestep_s: 0.0005\n", "  timestep_s: 0.0005\n  supply_cap_MPa: 0\n"), config::Error);
  EXPECT_THROW(rig_with("range_N: 1000.0}", "range_N: 1000.0, gain: 3.0}"), config::Error);
}

// A load cell with an offset and a gain error reads gain * T + offset (plus its noise): the
// controller never learns the error from the configuration, only from the reading.
TEST(SimulatedRig, LoadCellOffsetAndGainShiftTheReading) {
  OneDofRigParams p = rig();
  p.finger.pushes = {{"hold", 0.0, 10.0, 10.0, 0.0, true}};
  p.joint.agonist.loadcell_offset_N = 50.0;
  p.joint.agonist.loadcell_gain = 1.1;
  p.joint.antagonist.loadcell_offset_N = -40.0;
  OneDofRigBackend plant(p);
  plant.activate();
  io::Command c;
  c.joint_count = 1;
  c.joints[0] = {0.25e6, 0.3e6, 0.0};
  for (int k = 0; k < 2000; ++k) plant.write(c);
  io::SensorState s;
  double sum[2] = {0, 0};
  const int n = 1000;
  for (int k = 0; k < n; ++k) {
    plant.write(c);
    plant.read(s);
    sum[0] += s.joints[0].agonist_loadcell_N - (1.1 * plant.truth().muscle_force_N[0] + 50.0);
    sum[1] += s.joints[0].antagonist_loadcell_N - (plant.truth().muscle_force_N[1] - 40.0);
  }
  EXPECT_LT(std::abs(sum[0] / n), 0.2);
  EXPECT_LT(std::abs(sum[1] / n), 0.2);
  EXPECT_GT(plant.truth().muscle_force_N[1], 40.0);  // the antagonist's reading stayed above 0 (no clipping)
}

// A plant-only supply cap (a weaker compressor) holds the chamber below it whatever the command,
// while a plant without the cap follows the same command above it.
TEST(SimulatedRig, SupplyCapHoldsTheChamberBelowIt) {
  for (const double cap_Pa : {0.35e6, std::numeric_limits<double>::infinity()}) {
    OneDofRigParams p = rig();
    p.finger.pushes = {{"hold", 0.0, 10.0, 10.0, 0.0, true}};
    p.joint.supply_cap_Pa = cap_Pa;
    OneDofRigBackend plant(p);
    plant.activate();
    io::Command c;
    c.joint_count = 1;
    c.joints[0] = {0.6e6, 0.6e6, 0.0};
    double highest = 0;
    for (int k = 0; k < 1000; ++k) {
      plant.write(c);
      highest = std::max({highest, plant.truth().pressure_Pa[0], plant.truth().pressure_Pa[1]});
    }
    if (std::isfinite(cap_Pa)) {
      EXPECT_LE(highest, cap_Pa);
      EXPECT_GT(highest, 0.99 * cap_Pa);
    } else {
      EXPECT_GT(highest, 0.59e6);
    }
  }
}

// A payload the controller is not told adds its weight at the payload's lever: the hand holding
// the vented rig at 0 rad needs 1.5 kg * g more at the same lever (0.4 m, where the payload sits),
// within 3 %: the hand's stiffness lets the link sag 0.05 / 0.11 rad (cos: -1 %), and the motor's
// Coulomb friction (0.08 Nm) is up to 0.2 N at the finger either way.
TEST(SimulatedRig, UnknownPayloadWeighsAtThePayloadLever) {
  OneDofRigParams p = rig();
  p.payload_kg = 1.0;
  const double known_N = holding_force_N(p);
  p.unknown_payload_kg = 1.5;
  const double heavier_N = holding_force_N(p);
  EXPECT_NEAR(heavier_N - known_N, 1.5 * 9.81, 0.03 * 1.5 * 9.81);
  p.unknown_payload_kg = -1.5;
  EXPECT_THROW(OneDofRigBackend{p}, std::invalid_argument);
}

}  // namespace
}  // namespace peha::sim
