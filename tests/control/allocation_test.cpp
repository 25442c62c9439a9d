#include "peha/control/allocation.hpp"

#include "../support/nominal_models.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace peha::control {
namespace {

// Property test: 10^5 random requests, including absurd torques, angles, velocities, NaN and inf.
// Whatever comes in, every command is finite and within its limits: 0 <= force <= the muscle's
// ceiling (<= 2000 N), force >= pretension, 0 <= pressure <= supply, |motor| <= rating.
TEST(Allocation, LimitsNeverExceededUnderRandomRequests) {
  models::JointModel joint = peha::testing::rig_joint();
  joint.pretension_N = 60.0;
  AllocationParams params;
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> torque(-500.0, 500.0), angle(-3.0, 3.0), vel(-20.0, 20.0),
      force(-100.0, 5000.0), unit(0.0, 1.0);
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(), 1e300, -1e300};
  AllocationData data;
  AllocationOutput out;
  int nonfinite_cases = 0;
  for (int i = 0; i < 100000; ++i) {
    AllocationInput in;
    in.tau_desired_Nm = torque(rng);
    in.angle_rad = angle(rng);
    in.velocity_radps = vel(rng);
    in.agonist_loadcell_N = force(rng);
    in.antagonist_loadcell_N = force(rng);
    in.dt_s = 1e-3;
    if (unit(rng) < 0.02) {  // 2 % of the requests carry a special value somewhere
      double* fields[] = {&in.tau_desired_Nm, &in.angle_rad, &in.velocity_radps, &in.agonist_loadcell_N,
                          &in.antagonist_loadcell_N, &in.dt_s};
      *fields[rng() % 6] = specials[rng() % 5];
      ++nonfinite_cases;
    }
    allocate(joint, params, data, in, out);
    for (double p : {out.agonist_pressure_Pa, out.antagonist_pressure_Pa}) {
      ASSERT_TRUE(std::isfinite(p)) << "request " << i;
      ASSERT_GE(p, 0.0);
      ASSERT_LE(p, joint.supply_pressure_Pa);
    }
    ASSERT_LE(out.agonist_force_cmd_N, joint.agonist.max_force_N);
    ASSERT_LE(out.antagonist_force_cmd_N, joint.antagonist.max_force_N);
    ASSERT_LE(out.agonist_force_cmd_N, models::kMaxPamForce_N);
    ASSERT_GE(out.agonist_force_cmd_N, joint.pretension_N);
    ASSERT_GE(out.antagonist_force_cmd_N, joint.pretension_N);
    ASSERT_TRUE(std::isfinite(out.tau_motor_cmd_Nm));
    ASSERT_LE(std::abs(out.tau_motor_cmd_Nm), joint.motor_max_torque_Nm);
    ASSERT_TRUE(std::isfinite(out.tau_pam_cmd_Nm));
  }
  EXPECT_GT(nonfinite_cases, 1000);
}

// A steady positive torque goes to the agonist: (f1 - f2) r0 = tau at the pulley, at rest.
TEST(Allocation, SteadyTorqueSplitsIntoAgonistPullAndAntagonistPretension) {
  models::JointModel joint = peha::testing::rig_joint();
  joint.pretension_N = 40.0;
  AllocationParams params;
  AllocationData data;
  AllocationOutput out;
  AllocationInput in;
  in.tau_desired_Nm = 15.0;
  in.agonist_loadcell_N = 40.0 + 15.0 / joint.pulley_radius_m;
  in.antagonist_loadcell_N = 40.0;
  // The measured pressures are the model's for those forces: the load cells agree with the model
  // and are used (a load cell without a pressure that explains it would be dropped).
  in.agonist_pressure_Pa = models::inverse_pressure(joint.agonist.pam, in.agonist_loadcell_N,
                                                    joint.agonist.contraction_at_zero_angle, joint.supply_pressure_Pa).pressure_Pa;
  in.antagonist_pressure_Pa = models::inverse_pressure(joint.antagonist.pam, in.antagonist_loadcell_N,
                                                       joint.antagonist.contraction_at_zero_angle, joint.supply_pressure_Pa).pressure_Pa;
  for (int i = 0; i < 3000; ++i) allocate(joint, params, data, in, out);
  EXPECT_FALSE(out.flags & kLoadcellDisagrees);
  EXPECT_NEAR(out.tau_pam_cmd_Nm, 15.0, 1e-9);
  EXPECT_NEAR(out.agonist_force_cmd_N, 40.0 + 15.0 / 0.05, 1e-9);  // 340 N at v = 0 (no Bowden factor)
  EXPECT_NEAR(out.antagonist_force_cmd_N, 40.0, 1e-12);
  EXPECT_NEAR(out.tau_pam_measured_Nm, 15.0, 1e-9);
  EXPECT_NEAR(out.tau_motor_cmd_Nm, 0.0, 1e-9);  // nothing left for the motor
  // The pressure is the inverse model's at the rigid-wire contraction.
  const double eps = joint.agonist.contraction_at_zero_angle;
  EXPECT_NEAR(out.agonist_pressure_Pa, models::inverse_pressure(joint.agonist.pam, 340.0, eps, joint.supply_pressure_Pa).pressure_Pa, 1e-6);
}

// A torque step reaches the PAMs through the low-pass; the motor takes the gap meanwhile.
TEST(Allocation, MotorCoversTheFastPartOfATorqueStep) {
  const models::JointModel joint = peha::testing::rig_joint();
  AllocationParams params;  // 5 Hz PAM cut-off
  AllocationData data;
  AllocationOutput out;
  AllocationInput in;
  in.agonist_loadcell_N = in.antagonist_loadcell_N = joint.pretension_N;
  allocate(joint, params, data, in, out);
  in.tau_desired_Nm = 2.0;  // step of 2 Nm, within the motor's 2.5 Nm
  allocate(joint, params, data, in, out);
  EXPECT_LT(out.tau_pam_cmd_Nm, 0.07 * 2.0);  // one 1 ms step of a 5 Hz low-pass: 3.1 %
  EXPECT_NEAR(out.tau_motor_cmd_Nm, 2.0, 1e-9);  // load cells still show no PAM torque
  for (int i = 0; i < 1000; ++i) allocate(joint, params, data, in, out);  // 1 s = 31 time constants
  EXPECT_NEAR(out.tau_pam_cmd_Nm, 2.0, 1e-9);
}

// Negative torque goes to the antagonist and is capped by the DMSP-10's 630 N.
TEST(Allocation, NegativeTorqueLoadsTheAntagonistUpToItsCeiling) {
  const models::JointModel joint = peha::testing::rig_joint();
  AllocationParams params;
  AllocationData data;
  AllocationOutput out;
  AllocationInput in;
  in.tau_desired_Nm = -100.0;  // would need 2000 N at r0 = 0.05
  for (int i = 0; i < 2000; ++i) allocate(joint, params, data, in, out);
  EXPECT_EQ(out.antagonist_force_cmd_N, 630.0);
  EXPECT_EQ(out.agonist_force_cmd_N, joint.pretension_N);
  EXPECT_TRUE(out.flags & kForceClampedHigh);
}

}  // namespace
}  // namespace peha::control

namespace peha::control {
namespace {

/// The trim tests' joint: the rig's with a 60 N pretension.
models::JointModel trim_test_joint() {
  models::JointModel joint = peha::testing::rig_joint();
  joint.pretension_N = 60.0;
  return joint;
}

/// The trim tests' allocation: a load-cell trim of 4 /s, up to 600 N.
AllocationParams trim_test_params() {
  AllocationParams params;
  params.force_trim_rate_1ps = 4.0;
  params.force_trim_max_N = 600.0;
  return params;
}

/// An antagonist's load cell when the muscle makes `missing_N` less than the model says (never below 0 N).
auto antagonist_weaker_by(const models::JointModel& joint, double missing_N) {
  return [&joint, missing_N](const AllocationOutput& o) {
    return std::max(0.0, models::forward_force_N(joint.antagonist.pam, o.antagonist_pressure_Pa, o.antagonist_contraction) - missing_N);
  };
}

/// Steps the allocation `n` times on an ideal plant whose chamber pressure is the last command and
/// whose agonist load cell reads the model's force; the antagonist's reading is `antagonist(k)`.
template <class Reading>
void run_ideal(const models::JointModel& joint, const AllocationParams& params, AllocationData& data, AllocationOutput& out,
               int n, Reading antagonist, bool tension_expected = true) {
  for (int k = 0; k < n; ++k) {
    AllocationInput in;
    in.tension_expected = tension_expected;
    in.tau_desired_Nm = 5.0;
    in.agonist_pressure_Pa = out.agonist_pressure_Pa;
    in.antagonist_pressure_Pa = out.antagonist_pressure_Pa;
    in.agonist_loadcell_N = models::forward_force_N(joint.agonist.pam, out.agonist_pressure_Pa, out.agonist_contraction);
    in.antagonist_loadcell_N = antagonist(out);
    allocate(joint, params, data, in, out);
  }
}

// A load cell that reads far from what the pressure model says the muscle makes at the measured
// pressure (here a shorted antagonist cell reading 900 N at about 60 N) is dropped for that muscle
// within 0.2 s: the flag is raised, its trim is frozen, and the motor's PAM torque uses the
// model's force for it. Once it reads plausibly again it is trusted again.
TEST(Allocation, LoadcellThatDisagreesWithTheModelIsDropped) {
  const models::JointModel joint = trim_test_joint();
  const AllocationParams params = trim_test_params();
  AllocationData data;
  AllocationOutput out;
  auto agrees = [&](const AllocationOutput& o) {
    return models::forward_force_N(joint.antagonist.pam, o.antagonist_pressure_Pa, o.antagonist_contraction);
  };
  run_ideal(joint, params, data, out, 500, agrees);
  EXPECT_FALSE(out.flags & kLoadcellDisagrees);
  EXPECT_TRUE(out.loadcell_ok[1]);
  run_ideal(joint, params, data, out, 200, [](const AllocationOutput&) { return 900.0; });
  EXPECT_TRUE(out.flags & kLoadcellDisagrees);
  EXPECT_FALSE(out.loadcell_ok[1]);
  EXPECT_TRUE(out.loadcell_ok[0]);
  const double frozen_trim = out.antagonist_trim_N;
  run_ideal(joint, params, data, out, 500, [](const AllocationOutput&) { return 900.0; });
  EXPECT_EQ(out.antagonist_trim_N, frozen_trim);
  // The motor sees the model's antagonist force, not 900 N: the measured PAM torque stays near the
  // commanded one (a 900 N reading would make it about (F1 - 900) r0, 29 Nm lower).
  EXPECT_NEAR(out.tau_pam_measured_Nm, out.tau_pam_cmd_Nm, 1.0);
  run_ideal(joint, params, data, out, 1000, agrees);
  EXPECT_TRUE(out.loadcell_ok[1]);
  EXPECT_FALSE(out.flags & kLoadcellDisagrees);
}

// The tension floor by the model: an antagonist load cell reading 100 N high (within the check's
// tolerance at 60 N, so it is trusted) would trim the command down until the reading is 60 N, i.e.
// the wire at 0 N. The trim stops where the model's force (force + trim) is the pretension.
TEST(Allocation, TrimCannotTakeTheModelForceBelowThePretension) {
  const models::JointModel joint = trim_test_joint();
  const AllocationParams params = trim_test_params();
  AllocationData data;
  AllocationOutput out;
  bool floor_flag = false;
  for (int k = 0; k < 3000; ++k) {
    run_ideal(joint, params, data, out, 1, [&](const AllocationOutput& o) {
      return models::forward_force_N(joint.antagonist.pam, o.antagonist_pressure_Pa, o.antagonist_contraction) + 100.0;
    });
    floor_flag |= (out.flags & kTensionFloorByModel) != 0;
    ASSERT_GE(out.antagonist_force_cmd_N + out.antagonist_trim_N, joint.pretension_N - 1e-9) << k;
  }
  EXPECT_TRUE(out.loadcell_ok[1]);
  EXPECT_TRUE(floor_flag);
  EXPECT_NEAR(out.antagonist_trim_N, 0.0, 1e-9);
}

// The slack trim rate (force_trim_slack_rate_1ps): while the antagonist's load cell reads below the
// pretension (a muscle whose real pressure threshold the model misses: it makes 35 N less than the
// model says), its trim climbs at the slack rate; once the cell reads the pretension it integrates at
// the ordinary rate again, and a muscle pulling too hard is never trimmed down faster than that.
TEST(Allocation, TrimClimbsAtTheSlackRateOnlyWhileTheCellReadsBelowThePretension) {
  const models::JointModel joint = trim_test_joint();
  const AllocationParams params = trim_test_params();
  const auto weak = antagonist_weaker_by(joint, 35.0);
  auto strong = [&](const AllocationOutput& o) {
    return models::forward_force_N(joint.antagonist.pam, o.antagonist_pressure_Pa, o.antagonist_contraction) + 35.0;
  };
  auto trim_after = [&](double slack_rate_1ps, int steps, auto reading) {
    AllocationParams p = params;
    p.force_trim_slack_rate_1ps = slack_rate_1ps;
    AllocationData data;
    AllocationOutput out;
    run_ideal(joint, p, data, out, steps, reading);
    return out.antagonist_trim_N;
  };
  // 20 ms: the ordinary rate has barely started (4 /s x 35 N x 0.02 s ~ 3 N); 300 /s has caught up.
  EXPECT_LT(trim_after(0.0, 20, weak), 5.0);
  const double fast = trim_after(300.0, 20, weak);
  EXPECT_GT(fast, 30.0);
  EXPECT_LT(fast, 45.0);  // stops near the 35 N it lacks: above the pretension the ordinary rate
  // A muscle pulling 35 N more than the model says: the slack rate plays no part (same trim, bit for bit).
  EXPECT_EQ(trim_after(300.0, 500, strong), trim_after(0.0, 500, strong));
}

// While the wires refill from the start-up tare's vent (tension not yet expected) a cell below the
// pretension is a wire still taking up its slack, not a model that misses the threshold: the trim
// integrates at the ordinary rate there. At 300 /s it wound up during the take-up and the muscle
// overshot as its wire came taut (the shoulder's agonist to 520 N; with valves twice as fast the
// antagonist's pressure then led the monitor's valve model: pressure_high at start-up).
TEST(Allocation, TrimWaitsForTheRefillBeforeItsSlackRate) {
  const models::JointModel joint = trim_test_joint();
  const AllocationParams params = trim_test_params();
  const auto weak = antagonist_weaker_by(joint, 35.0);
  auto trim_after = [&](double slack_rate_1ps, bool tension_expected) {
    AllocationParams p = params;
    p.force_trim_slack_rate_1ps = slack_rate_1ps;
    AllocationData data;
    AllocationOutput out;
    run_ideal(joint, p, data, out, 20, weak, tension_expected);
    return out.antagonist_trim_N;
  };
  EXPECT_EQ(trim_after(300.0, false), trim_after(0.0, false));  // the ordinary rate, bit for bit
  EXPECT_LT(trim_after(300.0, false), 5.0);
  EXPECT_GT(trim_after(300.0, true), 30.0);  // once the wires are expected taut: the slack rate
}

// The operator's recovery after an outage (control::resume_allocation). While a supervisor held the
// muscles at other pressures, the trim integrated against commands that never went out: here the
// held antagonist's cell reads 20 N under a 60 N pretension for 1 s and the trim winds up (E3 re-armed
// its shoulder's antagonist toward 0.8 MPa that way and drove the arm onto its stop at 115 deg/s).
// Resumed, the next command is the pressure measured; not resumed, it is the wound trim's.
TEST(Allocation, AResumedAllocationStartsFromTheMeasuredPressureNotItsWoundTrim) {
  const models::JointModel joint = trim_test_joint();
  const AllocationParams params = trim_test_params();
  AllocationData data;
  AllocationOutput out;
  run_ideal(joint, params, data, out, 500, [&](const AllocationOutput& o) {
    return models::forward_force_N(joint.antagonist.pam, o.antagonist_pressure_Pa, o.antagonist_contraction);
  });
  AllocationInput held;
  held.tau_desired_Nm = 5.0;
  held.agonist_pressure_Pa = out.agonist_pressure_Pa;
  held.antagonist_pressure_Pa = out.antagonist_pressure_Pa;
  held.agonist_loadcell_N = models::forward_force_N(joint.agonist.pam, out.agonist_pressure_Pa, out.agonist_contraction);
  held.antagonist_loadcell_N = 20.0;
  for (int k = 0; k < 1000; ++k) allocate(joint, params, data, held, out);
  AllocationData wound = data;
  AllocationOutput wound_out = out;
  allocate(joint, params, wound, held, wound_out);
  resume_allocation(data);
  allocate(joint, params, data, held, out);
  EXPECT_NEAR(out.antagonist_pressure_Pa, held.antagonist_pressure_Pa, 1e3);
  EXPECT_NEAR(out.agonist_pressure_Pa, held.agonist_pressure_Pa, 1e3);
  EXPECT_GT(wound_out.antagonist_pressure_Pa - held.antagonist_pressure_Pa, 2e4);
}

}  // namespace
}  // namespace peha::control
