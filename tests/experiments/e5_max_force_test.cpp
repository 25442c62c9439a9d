#include "peha/experiments/e5_max_force/max_force.hpp"

#include "../support/verdict_checks.hpp"
#include "../support/shipped_scenarios.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace peha::experiments {
namespace {

/// A shorter run for the tests: a faster ramp (0.3 MPa/s) reaches the ceiling at ~1.5 s; 5 s in all.
E5Scenario fast_scenario() {
  E5Scenario s = test_support::shipped_e5();
  s.ramp.rate_Pa_per_s = 0.3e6;
  s.duration_s = 5.0;
  return s;
}

// The paper's Fig. 7 claim through the limits stage: the agonist's pressure ramps without end against
// the clamped joint; the limits' force-ceiling pressure stops the load cell at or below 2000 N
// (overshoot <= 5 N), it holds there, and it is the force ceiling that stops it.
TEST(E5, TheForceCeilingStopsTheRampAndTheForceHolds) {
  const E5Scenario s = fast_scenario();
  const E5Result r = run_e5_case(s, s.cases.front(), nullptr);
  EXPECT_TRUE(r.passed) << r.verdict.failures();
  // The supervisor's stage is on: the force held at the ceiling is what the limits shape, not a fault.
  EXPECT_NE(r.verdict.find("supervisor faults"), nullptr);
  EXPECT_DOUBLE_EQ(r.limit_N, 2000.0);
  EXPECT_LE(r.peak_force_N, 2005.0);
  EXPECT_LE(r.peak_truth_force_N, 2000.0);
  EXPECT_GT(r.held_force_N, 1800.0);  // the nominal model stops the force early, but not far
  EXPECT_EQ(r.stop, E5Stop::kForceCeiling);
  EXPECT_GE(r.ceiling_share_pct, 95.0);
  EXPECT_GE(r.time_at_limit_s, 2.0);
  EXPECT_LE(r.settle_s, 1.0);
  EXPECT_LT(r.max_clamp_deflection_deg, 0.1);  // the clamp holds the joint
  RecordProperty("peak_force_N", std::to_string(r.peak_force_N));
  RecordProperty("held_force_N", std::to_string(r.held_force_N));
}

// A broken limit: the controller's model of the agonist says it is 25 % weaker than the muscle is
// (the plant stronger than the model), so the ceiling's pressure makes more than 2000 N. The
// overshoot and the envelope's force check must fail the verdict.
TEST(E5, AModelWeakerThanTheMuscleFailsTheVerdict) {
  E5Scenario s = fast_scenario();
  auto& pam = s.joint.agonist.pam;
  pam.a_N_per_Pa *= 0.75;
  pam.b_N_per_Pa *= 0.75;
  pam.c_N_per_Pa *= 0.75;
  const E5Result r = run_e5_case(s, s.cases.front(), nullptr);
  EXPECT_FALSE(r.passed);
  EXPECT_GT(r.peak_force_N, 2050.0);
  const safety::Check* overshoot = r.verdict.find("agonist overshoot over the force ceiling");
  ASSERT_NE(overshoot, nullptr);
  EXPECT_FALSE(overshoot->passed());
  const safety::Check* envelope = r.verdict.find("joint agonist peak force");
  ASSERT_NE(envelope, nullptr);
  EXPECT_FALSE(envelope->passed());
}

// Without a force ceiling below the supply (a muscle whose model reaches 2000 N only above the
// supply) the supply stops the ramp: the stop mechanism says so and the ceiling-share check fails.
TEST(E5, ARampStoppedByTheSupplyInsteadOfTheCeilingFails) {
  E5Scenario s = fast_scenario();
  auto& pam = s.joint.agonist.pam;
  pam.a_N_per_Pa *= 0.3;
  pam.b_N_per_Pa *= 0.3;
  pam.c_N_per_Pa *= 0.3;
  // A model 3x weaker than the muscle is itself a fault the supervisor catches (the load cell
  // disagrees with the pressure model): with the stage on, it stops the ramp.
  const E5Result supervised = run_e5_case(s, s.cases.front(), nullptr);
  EXPECT_FALSE(supervised.passed);
  EXPECT_EQ(supervised.stop, E5Stop::kSupervisor);
  EXPECT_TRUE(testing::fails_on(supervised.verdict, "supervisor faults")) << supervised.verdict.failures();
  // Without it (this test measures which limit stops a ramp the model cannot cap), the supply does.
  s.limits.test_overrides.unchecked = ~0u;  // an unprotected controller, measured
  const E5Result r = run_e5_case(s, s.cases.front(), nullptr);
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.stop, E5Stop::kSupply);
  const safety::Check* share = r.verdict.find("agonist held cycles capped by the force ceiling");
  ASSERT_NE(share, nullptr);
  EXPECT_FALSE(share->passed());
}

// A ramp too short to hold fails the time at the limit.
TEST(E5, ARunThatEndsBeforeTheForceHoldsFailsTheTimeAtTheLimit) {
  E5Scenario s = fast_scenario();
  s.duration_s = 2.5;
  const E5Result r = run_e5_case(s, s.cases.front(), nullptr);
  EXPECT_FALSE(r.passed);
  const safety::Check* held = r.verdict.find("agonist time at the limit");
  ASSERT_NE(held, nullptr);
  EXPECT_FALSE(held->passed());
}

/// The rig behind a board that reports its outputs armed a few cycles after the host asks (as a
/// board over UDP does: its armed flag comes back with its next state packet).
class LateArmingBoard final : public io::Backend {
 public:
  LateArmingBoard(io::Backend& inner, int late_cycles) : inner_(inner), late_(late_cycles) {}
  const io::BackendInfo& info() const override { return inner_.info(); }
  void configure() override { inner_.configure(); }
  void activate() noexcept override { inner_.activate(), reads_since_activate_ = 0; }
  void deactivate() noexcept override { inner_.deactivate(); }
  void estop() noexcept override { inner_.estop(); }
  io::BackendStatus status() const noexcept override {
    io::BackendStatus s = inner_.status();
    s.active = s.active && reads_since_activate_ > late_;
    return s;
  }
  bool read(io::SensorState& state) noexcept override { return ++reads_since_activate_, inner_.read(state); }
  bool write(const io::Command& command) noexcept override { return inner_.write(command); }

 private:
  io::Backend& inner_;
  int late_, reads_since_activate_ = 0;
};

// The limit is reached when the limits cap the ramp, not when the outputs wait to be armed: a board
// that arms 3 cycles late (CI, loaded, over UDP) once read "reached at 0 s, held after 1.2 s".
TEST(E5, OutputsArmedLateDoNotCountAsReachingTheLimit) {
  const E5Scenario s = fast_scenario();
  sim::OneDofRigBackend plant(e5_plant_params(s, s.cases.front()));
  LateArmingBoard board(plant, 3);
  const E5Result r = run_e5_on(s, s.cases.front(), board, &plant, nullptr);
  EXPECT_TRUE(r.passed) << r.verdict.failures();
  EXPECT_GT(r.reach_s, s.ramp.start_s);  // the ramp starts from below the ceiling
  EXPECT_LE(r.settle_s, 0.5);
}

TEST(E5, ARampFasterThanThePressureRateLimitIsRejected) {
  const std::string yaml = [] {
    std::ifstream in(PEHA_SOURCE_DIR "/configs/e5_max_force.yaml");
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    text.replace(text.find("rate_MPa_per_s: 0.10"), 20, "rate_MPa_per_s: 5.00");
    return text;
  }();
  EXPECT_THROW(read_e5(config::Document::load_string(yaml, "e5_max_force.yaml")), config::Error);
}

}  // namespace
}  // namespace peha::experiments
