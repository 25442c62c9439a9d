// The supervisor's plausibility stage (safety::FaultMonitor inside safety::LimitedBackend) on the
// simulated E1 rig with injected plant faults: each fault is detected by its named flag within a
// bounded number of control cycles and the run takes the flag's designed safe state; a nominal run
// raises nothing; with the check disabled (a broken supervisor) the same fault goes unseen.
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/fault_monitor.hpp"
#include "peha/safety/limits.hpp"
#include "peha/sim/plant_faults.hpp"
#include "../support/shipped_scenarios.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <cmath>

namespace peha {
namespace {

constexpr double kFaultAt_s = 3.0;  // the link is held still by the controller here

experiments::E1Scenario short_e1() {
  experiments::E1Scenario s = peha::test_support::shipped_e1();
  s.duration_s = 5.0;
  s.plant.finger.pushes.resize(1);  // the start-up hold only
  s.probe_direction.resize(1);
  // The shipped configuration: the stage on, the controller's start-up tare on (the wires go slack on
  // purpose for about 1.7 s; the slack checks arm 1 s after the outputs follow and once a wire is taut).
  EXPECT_EQ(s.limits.monitor.unmodelled, 0u);
  EXPECT_GT(s.controller.allocation.loadcell_check.tare_s, 0.0);
  return s;
}

experiments::E1Result run_with(experiments::E1Scenario s, const std::string& spec) {
  if (!spec.empty()) s.plant.faults.push_back(sim::parse_fault_spec(spec, sim::one_dof_rig_joint_names(), s.duration_s));
  return experiments::run_e1_case(s, s.cases.front(), nullptr);
}

TEST(FaultMonitor, NominalRunRaisesNoFault) {
  const auto r = run_with(short_e1(), "");
  EXPECT_EQ(r.faults, 0u) << r.fault_reason;
  EXPECT_EQ(r.fault_flags, 0u);
}

struct Expect {
  const char* spec;
  std::uint32_t flag;
  int max_cycles;  // from the injection to the latch
  safety::SafeAction action;
};

class InjectedFault : public ::testing::TestWithParam<Expect> {};

TEST_P(InjectedFault, IsDetectedByItsFlagWithinItsCyclesAndTakesItsSafeState) {
  const Expect e = GetParam();
  const auto r = run_with(short_e1(), std::string(e.spec));
  ASSERT_EQ(r.faults, 1u) << e.spec;
  EXPECT_TRUE(r.fault_flags & e.flag) << e.spec << ": " << r.fault_reason;
  EXPECT_NE(r.fault_reason.find(safety::fault_flag_name(e.flag)), std::string::npos) << r.fault_reason;
  EXPECT_NE(r.fault_reason.find(safety::safe_action_name(e.action)), std::string::npos) << r.fault_reason;
  const double at = std::stod(r.fault_reason.substr(r.fault_reason.find(" at ") + 4));
  EXPECT_LE(std::lround((at - kFaultAt_s) / 1e-3), e.max_cycles) << r.fault_reason;
  EXPECT_FALSE(r.verdict.passed()) << "a faulted run must fail its verdict (exit code 3)";
  // Whatever the safe state, the hard limits hold: no muscle above its ceiling.
  EXPECT_LE(r.peak_muscle_force_N[0], 2000.0);
  EXPECT_LE(r.peak_muscle_force_N[1], 2000.0);
}

INSTANTIATE_TEST_SUITE_P(
    E1Holding, InjectedFault,
    ::testing::Values(Expect{"loadcell_stuck@3:agonist", safety::kFaultLoadcellStuck, 8, safety::SafeAction::kDescend},
                      Expect{"loadcell_disconnected@3:antagonist", safety::kFaultLoadcellDisconnected, 4, safety::SafeAction::kDescend},
                      // A full-scale reading the pressure model cannot explain is a load-cell fault, not an
                      // over-force: descend on the model (venting would drop the loaded link).
                      Expect{"loadcell_saturated@3:agonist", safety::kFaultLoadcellDisagrees, 2, safety::SafeAction::kDescend},
                      // No trusted angle: hold what the muscles hold (the fault matrix measured 115-414
                      // deg/s when this vented).
                      Expect{"encoder_jump@3", safety::kFaultEncoderJump, 2, safety::SafeAction::kHold},
                      Expect{"controller_nan@3", safety::kFaultNonFiniteCommand, 1, safety::SafeAction::kHold},
                      // The wire's tension floor is armed once the wire is taut: a break is seen in 3 cycles
                      // (it was 13, as a disconnected cell, while the check had to be off).
                      Expect{"wire_break@3:agonist", safety::kFaultTensionFloor, 5, safety::SafeAction::kDescend},
                      // The valve's 5 ms dead time and 30 ms lag: nothing shows for 5 cycles, 8 kPa after about 16
                      // (22 measured; 43, as pressure_high, before the rise check). Descend: noise can trip
                      // the rise check; the valve that keeps filling escalates to vent (below).
                      Expect{"valve_stuck_open@3:agonist", safety::kFaultPressureRise, 25, safety::SafeAction::kDescend},
                      // The supply sensor on the valve manifold: a loss holds (no air to brake a descent
                      // with), half the supply descends on what is left. Both were unobservable at rest.
                      Expect{"supply_zero@3", safety::kFaultSupplyLoss, 3, safety::SafeAction::kHold},
                      Expect{"supply_half@3", safety::kFaultSupplyLow, 3, safety::SafeAction::kDescend}));

// A valve stuck open is first seen by the rise check (descend, as a false rise would be) and, as it
// keeps filling, by pressure_high, which vents it: the run ends vented, as before the rise check.
TEST(FaultMonitor, AValveThatKeepsFillingEscalatesFromDescendToVent) {
  const auto r = run_with(short_e1(), "valve_stuck_open@3:agonist");
  EXPECT_NE(r.fault_flags & safety::kFaultPressureRise, 0u) << r.fault_reason;
  EXPECT_NE(r.fault_flags & safety::kFaultPressureHigh, 0u) << r.fault_reason;
  EXPECT_EQ(safety::safe_action(safety::kFaultPressureHigh), safety::SafeAction::kVent);
}

TEST(FaultMonitor, BrokenSupervisorWithTheCheckDisabledMissesTheFault) {
  experiments::E1Scenario s = short_e1();
  s.limits.test_overrides.unchecked = safety::kFaultLoadcellStuck | safety::kFaultLoadcellDisagrees;
  const auto r = run_with(s, "loadcell_stuck@3:agonist");
  EXPECT_EQ(r.fault_flags & safety::kFaultLoadcellStuck, 0u);
  // The test above (loadcell_stuck detected within its 8-cycle window) would fail on this supervisor.
}

TEST(FaultSpec, ParsesStrictlyAndNamesWhatIsWrong) {
  const std::vector<std::string> joints = {"joint"};
  const auto f = sim::parse_fault_spec("loadcell_bias@2.5:joint.antagonist=300", joints, 10.0);
  EXPECT_EQ(f.kind, sim::FaultKind::kLoadcellBias);
  EXPECT_DOUBLE_EQ(f.time_s, 2.5);
  EXPECT_EQ(f.muscle, 1);
  EXPECT_DOUBLE_EQ(f.value, 300.0);
  EXPECT_THROW(sim::parse_fault_spec("loadcell_stuck@2", joints, 10.0), std::invalid_argument);       // no muscle
  EXPECT_THROW(sim::parse_fault_spec("bogus@2", joints, 10.0), std::invalid_argument);                // kind
  EXPECT_THROW(sim::parse_fault_spec("encoder_jump@20", joints, 10.0), std::invalid_argument);        // after the run
  EXPECT_THROW(sim::parse_fault_spec("motor_fault@1:joint=3", joints, 10.0), std::invalid_argument);  // takes no value
  EXPECT_THROW(sim::parse_fault_spec("wire_break@1:elbow.agonist", joints, 10.0), std::invalid_argument);
}

// The check table (safety::kChecks, also a static_assert): one row per flag at its bit's index, each
// name once, every flag with a safe state; fault_flag_name and safe_action read it.
TEST(FaultMonitor, EveryFlagHasOneRowOfTheCheckTableInBitOrder) {
  std::set<std::string> names;
  for (int i = 0; i < safety::kFaultFlagCount; ++i) {
    const std::uint32_t flag = 1u << i;
    const safety::CheckInfo& row = safety::kChecks[static_cast<std::size_t>(i)];
    EXPECT_EQ(row.flag, flag);
    EXPECT_TRUE(names.insert(row.name).second) << row.name;
    EXPECT_STREQ(safety::fault_flag_name(flag), row.name);
    EXPECT_EQ(safety::safe_action(flag), row.action);
    EXPECT_NE(row.action, safety::SafeAction::kNone) << row.name;
    EXPECT_NE(row.parameter, nullptr) << row.name;
  }
  const std::uint32_t past_the_table = 1u << safety::kFaultFlagCount;
  EXPECT_STREQ(safety::fault_flag_name(0), "none");
  EXPECT_STREQ(safety::fault_flag_name(past_the_table), "none");
  EXPECT_EQ(safety::safe_action(past_the_table), safety::SafeAction::kNone);
}

}  // namespace
}  // namespace peha

namespace peha {
namespace {

// A real over-force (the load cell and the pressure model agree: the muscle is driven past its
// ceiling, here by a valve stuck open with the plausibility stage on) is relieved by venting; the
// force_ceiling flag is kept for that case only.
/// What the monitor is given for E1's one joint (its model, a +-1 rad range) and a one-joint sample.
struct E1JointView {
  experiments::E1Scenario scenario = short_e1();
  std::array<const models::JointModel*, io::kMaxJoints> joints{};
  std::array<double, io::kMaxJoints> lo{}, hi{};
  io::SensorState state;
  E1JointView() {
    joints[0] = &scenario.controller.joint;
    lo[0] = -1.0;
    hi[0] = 1.0;
    state.joint_count = 1;
  }
  E1JointView(const E1JointView&) = delete;  // joints points into scenario
  E1JointView& operator=(const E1JointView&) = delete;
  void check(safety::FaultMonitor& monitor, bool outputs_follow) const { monitor.check_sample(state, joints, lo, hi, outputs_follow); }
};

/// When E1's joint is first carried (both wires taut), s (NaN: never in 4 s), for cells that read a
/// `zero_N` offset on top of their wires' tension, the agonist's wire slack (0 N) until 1.5 s and then
/// taking up to 60 N over 1 s; the controller declares `declared_N` as both cells' zero.
double carried_at_s(double zero_N, double declared_N) {
  safety::FaultMonitor monitor(safety::MonitorParams{}, 1e-3);
  E1JointView view;
  io::SensorState& state = view.state;
  state.joints[0].agonist_pressure_Pa = state.joints[0].antagonist_pressure_Pa = 0.1e6;
  io::Command declared;
  declared.joint_count = 1;
  declared.joints[0] = {0.1e6, 0.1e6, 0.0, {declared_N, declared_N}};
  for (int k = 0; k < 4000; ++k) {
    state.time_s = 1e-3 * k;
    const double noise_N = 0.01 * (k % 7);
    const double agonist_tension_N = 60.0 * std::clamp(state.time_s - 1.5, 0.0, 1.0);
    state.joints[0].agonist_loadcell_N = zero_N + agonist_tension_N + noise_N;
    state.joints[0].antagonist_loadcell_N = zero_N + 60.0 + noise_N;
    view.check(monitor, true);
    if (monitor.carried(0)) return state.time_s;
    monitor.check_command(declared, state.time_s);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// A wire is taut by its tension, not by its cell's zero: a zero above the taut level (here +35 N
// against 0.5 x 60 N; on the arm +20 N against 20 N) reads a slack wire as taut, and judged on the
// raw cell that armed the slack and drift checks before the wire took up its slack (the arm's E3 then
// latched loadcell_drift during the refill and fell, 73-130 %). Less the zero the controller's
// start-up tare declares, the joint is carried only once the wire's tension passes 30 N (at 2.0 s,
// plus the 50 ms level filter); with the tare's zero undeclared it is carried before 1.6 s.
TEST(FaultMonitor, AWireIsTautByItsTensionLessTheDeclaredZero) {
  const double tared = carried_at_s(35.0, 35.0);
  EXPECT_GE(tared, 2.0);
  EXPECT_LE(tared, 2.1);
  EXPECT_LT(carried_at_s(35.0, 0.0), 1.6);
  EXPECT_NEAR(carried_at_s(0.0, 0.0), tared, 0.005);  // no zero: the same wire, the same moment
}

TEST(FaultMonitor, AnOverForceThePressureModelConfirmsIsVented) {
  safety::MonitorParams p;
  safety::FaultMonitor monitor(p, 1e-3);
  E1JointView view;
  io::SensorState& state = view.state;
  state.time_s = 1.0;
  state.joints[0].angle_rad = 0.0;
  state.joints[0].agonist_pressure_Pa = 0.8e6;  // the supply: the model's force is far above 2000 N here
  state.joints[0].agonist_loadcell_N = 2400.0;
  state.joints[0].antagonist_pressure_Pa = 0.2e6;
  state.joints[0].antagonist_loadcell_N = 60.0;
  view.check(monitor, false);
  EXPECT_TRUE(monitor.flags() & safety::kFaultForceCeiling) << monitor.reason();
  EXPECT_EQ(monitor.action(), safety::SafeAction::kVent);
}

/// Feeds `monitor` `cycles` samples of E1's joint at 1 kHz, both muscles at 0.1 MPa measured;
/// `cells(k, noise_N)` gives sample k's agonist and antagonist load cells (`noise_N`: a live cell
/// never repeats its code).
void feed_at_constant_pressure(safety::FaultMonitor& monitor, int cycles, const std::function<std::array<double, 2>(int, double)>& cells) {
  E1JointView view;
  io::SensorState& state = view.state;
  state.joints[0].agonist_pressure_Pa = 0.1e6;
  state.joints[0].antagonist_pressure_Pa = 0.1e6;
  for (int k = 0; k < cycles; ++k) {
    state.time_s = 1e-3 * k;
    const std::array<double, 2> cell_N = cells(k, 0.01 * (k % 7));
    state.joints[0].agonist_loadcell_N = cell_N[0];
    state.joints[0].antagonist_loadcell_N = cell_N[1];
    view.check(monitor, true);
  }
}

// A wire that reads code 0 after it was taut: on a joint whose tension is checked that is a
// disconnected cell (descend); on a joint whose wires may go slack by design (tension not checked:
// the constant-pressure wrist) a slack wire reads the same 0, so nothing is raised (the arm's
// identification latched it on the wrist before, refusing muscles -15 %).
std::uint32_t flags_after_a_taut_wire_reads_zero(bool tension_checked) {
  safety::MonitorParams p;
  p.tension_checked[0] = tension_checked;
  safety::FaultMonitor monitor(p, 1e-3);
  // 1.5 s taut at the pretension, then the antagonist's cell at 0.
  feed_at_constant_pressure(monitor, 2000, [](int k, double noise_N) {
    return std::array<double, 2>{60.0 + noise_N, k < 1500 ? 60.0 + noise_N : 0.0};
  });
  return monitor.flags();
}

/// Flags after a taut agonist whose cell moves by `change_N` over `over_s` at constant pressure.
std::uint32_t flags_after_a_cell_moves(double change_N, double over_s) {
  safety::MonitorParams p;
  safety::FaultMonitor monitor(p, 1e-3);
  // 1.5 s taut, then the change, then the rest of 4 s.
  feed_at_constant_pressure(monitor, 4000, [&](int k, double noise_N) {
    const double t_change = 1e-3 * k - 1.5;
    const double moved = t_change <= 0 ? 0.0 : change_N * std::min(1.0, over_s > 0 ? t_change / over_s : 1.0);
    return std::array<double, 2>{60.0 + moved + noise_N, 60.0 + noise_N};
  });
  return monitor.flags();
}

// A cell that jumps 150 N while the pressure stays is a load-cell fault (a bias, a slipped clamp);
// the same 150 N arriving over 2 s (a drift the model's error can have) is not a step, and the
// disagreement check (300 N + 75 %) judges it instead.
TEST(FaultMonitor, ALoadCellStepIsRaisedButASlowDriftIsNot) {
  EXPECT_TRUE(flags_after_a_cell_moves(150.0, 0.0) & safety::kFaultLoadcellStep);
  EXPECT_FALSE(flags_after_a_cell_moves(150.0, 2.0) & safety::kFaultLoadcellStep);
  EXPECT_FALSE(flags_after_a_cell_moves(60.0, 0.0) & safety::kFaultLoadcellStep);  // below the 100 N step
}

/// When loadcell_drift latches (NaN: never in 20 s) for a still, taut E1 joint at constant pressure whose
/// agonist cell creeps `drift_N_per_s` from 1.5 s, after a relaxation of `relax_N` (time constant 1 s).
double drift_latched_s(double drift_N_per_s, double relax_N, std::uint32_t unchecked = 0) {
  safety::CheckOverrides o;
  o.unchecked = unchecked;
  safety::FaultMonitor monitor(safety::MonitorParams{}, 1e-3, o);
  feed_at_constant_pressure(monitor, 20000, [&](int k, double noise_N) {
    const double t_s = std::max(0.0, 1e-3 * k - 1.5);
    return std::array<double, 2>{300.0 + relax_N * (1.0 - std::exp(-t_s)) + drift_N_per_s * t_s + noise_N, 60.0 + noise_N};
  });
  return monitor.flags() & safety::kFaultLoadcellDrift ? monitor.first().time_s : std::numeric_limits<double>::quiet_NaN();
}

// Issue 29: a cell whose zero creeps 10 N/s while its joint is still is raised (loadcell_drift,
// descend) once the still samples' change passes 80 N: 80 / (10 - 0.5 leak) N/s after the 0.5 s
// settle and the 0.5 s filter, about 10 s; a muscle that relaxes 40 N after it stops (the arm's
// relax 30-55 N) is not; with the check off the drift is not raised at all.
TEST(FaultMonitor, ALoadCellZeroThatCreepsIsRaisedButARelaxingMuscleIsNot) {
  const double latched_s = drift_latched_s(10.0, 0.0);
  EXPECT_GE(latched_s, 1.5 + 8.0);
  EXPECT_LE(latched_s, 1.5 + 11.0);
  EXPECT_EQ(safety::safe_action(safety::kFaultLoadcellDrift), safety::SafeAction::kDescend);
  EXPECT_TRUE(std::isnan(drift_latched_s(0.0, 40.0)));
  EXPECT_TRUE(std::isnan(drift_latched_s(0.0, -40.0)));
  EXPECT_TRUE(std::isnan(drift_latched_s(10.0, 0.0, safety::kFaultLoadcellDrift)));
}

/// The last command sent to E1's antagonist (after the limits and vent_escalated) and the flags, when
/// the link, held at 0.5 rad, drops one sample at 115 deg/s at 1.5 s (joint_speed: descend) and then
/// keeps descending at `down_degps` for 1 s whatever the governor commands. The pressures follow
/// the commands through the monitor's own valve model (dead time, rate, lag), so no pressure check trips.
std::pair<std::uint32_t, double> after_a_descent_at(double down_degps, std::uint32_t unchecked = 0) {
  safety::MonitorParams p;
  safety::CheckOverrides o;
  o.unchecked = unchecked;
  safety::FaultMonitor monitor(p, 1e-3, o);
  E1JointView view;
  io::SensorState& s = view.state;
  safety::LimitsModel limits = view.scenario.limits;
  safety::LimitsData data;
  safety::JointModels models{};
  models[0] = &view.scenario.controller.joint;
  io::Command sent;
  sent.joint_count = 1;
  std::array<std::array<double, 8>, 2> line{};  // the valve's dead time (5 cycles)
  std::array<double, 2> setpoint_Pa{0.3e6, 0.1e6}, pressure_Pa = setpoint_Pa;
  line[0].fill(0.3e6);
  line[1].fill(0.1e6);
  double angle_rad = 0.5;
  for (int k = 0; k < 2500; ++k) {
    s.time_s = 1e-3 * k;
    if (k == 1500) angle_rad -= models::deg_to_rad(115.0) * 1e-3;
    if (k > 1500) angle_rad -= models::deg_to_rad(down_degps) * 1e-3;
    s.joints[0].angle_rad = angle_rad;
    s.joints[0].agonist_pressure_Pa = pressure_Pa[0];
    s.joints[0].antagonist_pressure_Pa = pressure_Pa[1];
    s.joints[0].agonist_loadcell_N = 300.0 + 0.01 * (k % 7);
    s.joints[0].antagonist_loadcell_N = 60.0 + 0.01 * (k % 7);
    view.check(monitor, true);
    sent.joints[0].agonist_pressure_Pa = 0.3e6;  // the controller's (replaced by the governor's under descend)
    sent.joints[0].antagonist_pressure_Pa = 0.1e6;
    sent.joints[0].motor_torque_Nm = 0.0;
    monitor.shape(sent);
    safety::apply_limits(limits, models, data, s, sent);
    monitor.vent_escalated(sent);
    monitor.sent(sent);
    const double command_Pa[2] = {sent.joints[0].agonist_pressure_Pa, sent.joints[0].antagonist_pressure_Pa};
    for (int m = 0; m < 2; ++m) {  // the monitor's valve model: dead time, rate limit, first-order lag
      auto& l = line[static_cast<std::size_t>(m)];
      std::rotate(l.rbegin(), l.rbegin() + 1, l.rend());
      l[0] = command_Pa[m];
      const double delayed_Pa = l[static_cast<std::size_t>(std::lround(p.valve_dead_time_s / 1e-3))];
      const double step_Pa = p.valve_rate_Pa_per_s * 1e-3;
      auto& sp = setpoint_Pa[static_cast<std::size_t>(m)];
      sp += std::clamp(delayed_Pa - sp, -step_Pa, step_Pa);
      pressure_Pa[static_cast<std::size_t>(m)] += (1.0 - std::exp(-1e-3 / p.valve_lag_s)) * (sp - pressure_Pa[static_cast<std::size_t>(m)]);
    }
  }
  return {monitor.flags(), sent.joints[0].antagonist_pressure_Pa};
}

/// The angle (deg) at which joint_range is first raised for a joint moving at `degps` from 0 toward
/// its lower end (range -1..1 rad, -57.3 deg), NaN if never within 4 s (the monitor's defaults,
/// with `lead_s` and `brake_degps2`).
double range_raised_at_deg(double degps, double lead_s, double brake_degps2, bool governed = true) {
  safety::MonitorParams p;
  p.governed[0] = governed;
  p.range_lead_s = lead_s;
  p.range_brake_radps2 = models::deg_to_rad(brake_degps2);
  p.max_joint_speed_radps = models::deg_to_rad(1000.0);  // the range alone
  safety::FaultMonitor monitor(p, 1e-3);
  E1JointView view;
  io::SensorState& s = view.state;
  double angle_rad = 0.0;
  for (int k = 0; k < 4000; ++k) {
    s.time_s = 1e-3 * k;
    if (k > 100) angle_rad -= models::deg_to_rad(degps) * 1e-3;
    s.joints[0].angle_rad = angle_rad;
    s.joints[0].agonist_pressure_Pa = 0.3e6;
    s.joints[0].antagonist_pressure_Pa = 0.1e6;
    s.joints[0].agonist_loadcell_N = 300.0 + 0.01 * (k % 7);
    s.joints[0].antagonist_loadcell_N = 60.0 + 0.01 * (k % 7);
    view.check(monitor, true);
    if (monitor.flags() & safety::kFaultJointRange) return models::rad_to_deg(angle_rad);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Issue 29: the range is judged ahead, as the board's range vent: the angle led by the speed over the
// valves' reaction (40 ms) and the distance 2000 deg/s^2 takes to stop it. A joint heading for its
// stop at 300 deg/s is raised 34.5 deg before its end and margin (-57.3 - 4.6 deg): an elbow whose
// load cell crept let it fall onto its stop at 327 deg/s, 2.2 deg into it, before any check could
// tell; led, it is caught inside its range. Slow (20 deg/s) it is raised within 1.3 deg of the end and
// margin; judged on the angle alone, only past them.
TEST(FaultMonitor, AJointHeadingForItsStopFasterThanItCanStopIsRaisedInsideTheRange) {
  const double fast_deg = range_raised_at_deg(300.0, 0.04, 2000.0);
  EXPECT_NEAR(fast_deg, -57.3 - 4.6 + 12.0 + 22.5, 1.0);  // lead 12 deg, stopping 22.5, beyond the margin 4.6
  const double slow_deg = range_raised_at_deg(20.0, 0.04, 2000.0);
  EXPECT_LT(slow_deg, -57.3 - 4.6 + 1.3);
  const double unled_deg = range_raised_at_deg(300.0, 0.0, 1e9);
  EXPECT_LT(unled_deg, -57.3 - 4.5);
}

// A joint the safe state does not govern (the arm's wrist at its constant pressures) is stopped by its
// own muscles' spring, far harder than range_brake_degps2, and nothing the supervisor does brakes it:
// its range is judged on the angle. Led, E4's brisk wrist swinging at 430-470 deg/s near -4 deg was
// raised at 1.13-1.15 x its 60 deg range, the first fault of 11 of the robustness matrix's E4 cases.
TEST(FaultMonitor, AJointTheSafeStateDoesNotGovernIsJudgedOnItsAngle) {
  const double governed_deg = range_raised_at_deg(300.0, 0.04, 2000.0, true);
  const double passive_deg = range_raised_at_deg(300.0, 0.04, 2000.0, false);
  EXPECT_GT(governed_deg, -57.3 - 4.6 + 30.0);
  EXPECT_LT(passive_deg, -57.3 - 4.5);
  EXPECT_GT(passive_deg, -57.3 - 4.6 - 0.5);
}

// Issue 29: a descent the governor cannot slow (the link keeps falling at 45 deg/s whatever the
// agonist is asked for) escalates after descent_runaway_window_s: descent_runaway vents the muscle
// that pulls the link down (the antagonist, 0 Pa below the limits' pretension floor); the carrying
// agonist is never vented. A descent at 20 deg/s (below 30) is the governor's to slow: nothing
// escalates. With the check off the runaway keeps the antagonist pulling.
TEST(Descend, ARunawayTheGovernorCannotSlowVentsTheMusclePullingDown) {
  const auto [flags, antagonist_Pa] = after_a_descent_at(45.0);
  EXPECT_TRUE(flags & safety::kFaultJointSpeed);
  EXPECT_TRUE(flags & safety::kFaultDescentRunaway);
  EXPECT_EQ(antagonist_Pa, 0.0);
  EXPECT_FALSE(flags & (safety::kFaultPressureHigh | safety::kFaultPressureLow | safety::kFaultSupplyLoss));
  const auto [slow_flags, slow_antagonist_Pa] = after_a_descent_at(20.0);
  EXPECT_FALSE(slow_flags & safety::kFaultDescentRunaway);
  EXPECT_GT(slow_antagonist_Pa, 0.0);
  const auto [off_flags, off_antagonist_Pa] = after_a_descent_at(45.0, safety::kFaultDescentRunaway);
  EXPECT_FALSE(off_flags & safety::kFaultDescentRunaway);
  EXPECT_GT(off_antagonist_Pa, 0.0);
}

/// A monitor with the default parameters (stage on) on E1's joint, both muscles at 0.1 MPa.
struct MonitoredE1 {
  safety::FaultMonitor monitor{[] {
    safety::MonitorParams p;
    return p;
  }(), 1e-3};
  E1JointView view;
  MonitoredE1() { view.state.joints[0].agonist_pressure_Pa = view.state.joints[0].antagonist_pressure_Pa = 0.1e6; }
};

/// Flags after 1 s of commands of `commanded_Nm` on E1's motor while the driver's monitor reads
/// what the command of `latency_cycles` before asked for (`dead`: 0 Nm whatever the command).
/// With `board_cut` the board reports the motor cut by its range (io::kBoardMotorOff) on every sample.
std::uint32_t flags_after_motor_commands(double commanded_Nm, int latency_cycles, bool dead, bool has_monitor = true, bool board_cut = false) {
  MonitoredE1 e1;
  safety::FaultMonitor& monitor = e1.monitor;
  E1JointView& view = e1.view;
  io::SensorState& state = view.state;
  std::vector<double> sent;
  for (int k = 0; k < 1000; ++k) {
    state.time_s = 1e-3 * k;
    const double noise_N = 0.01 * (k % 7);
    state.joints[0].agonist_loadcell_N = state.joints[0].antagonist_loadcell_N = 60.0 + noise_N;
    const double shown = k > latency_cycles ? sent[static_cast<std::size_t>(k - 1 - latency_cycles)] : 0.0;
    state.joints[0].motor_torque_Nm = !has_monitor ? std::numeric_limits<double>::quiet_NaN() : dead ? 0.0 : shown;
    state.joints[0].board_limits = board_cut ? io::kBoardMotorOff : 0;
    view.check(monitor, true);
    io::Command c;
    c.joint_count = 1;
    c.joints[0].agonist_pressure_Pa = c.joints[0].antagonist_pressure_Pa = 0.1e6;
    c.joints[0].motor_torque_Nm = commanded_Nm * std::sin(0.05 * k);  // a motor share that swings through 0 (126 ms period)
    monitor.sent(c);
    sent.push_back(c.joints[0].motor_torque_Nm);
  }
  return monitor.flags();
}

// The motor driver's current monitor against the commands sent: a dead driver (0 Nm while asked for
// up to 1.5 Nm) is raised (hold: the muscles keep what they hold, motor off); a live one is not, also
// when the link shows each sample 8 cycles late (the emulator's --delay-ms 3 shows 3-4); a motor asked
// for less than the tolerance (0.2 of 0.25 Nm) is harmless and not observable; without a monitor
// (NaN: the channel map has none) nothing is checked.
TEST(FaultMonitor, AMotorThatDoesNotMakeItsTorqueIsRaisedAndALateSampleIsNot) {
  EXPECT_TRUE(flags_after_motor_commands(1.5, 0, true) & safety::kFaultMotorDisagrees);
  EXPECT_EQ(safety::safe_action(safety::kFaultMotorDisagrees), safety::SafeAction::kHold);
  EXPECT_EQ(flags_after_motor_commands(1.5, 0, false), 0u);
  EXPECT_EQ(flags_after_motor_commands(1.5, 8, false), 0u);
  EXPECT_TRUE(flags_after_motor_commands(1.5, 30, false) & safety::kFaultMotorDisagrees);  // far beyond the 10-cycle window
  EXPECT_EQ(flags_after_motor_commands(0.2, 0, true), 0u);
  EXPECT_EQ(flags_after_motor_commands(1.5, 0, true, false), 0u);  // no monitor (NaN): not checked
}

// The board reports each muscle its own limits vent and each motor its range cuts
// (io::JointSensors::board_limits). A motor the board cut reads 0 Nm while the host asks for 1.5 Nm:
// not a dead driver. A muscle the board vented is board_limit at once, with the muscle named, and
// descends on the other; not while the outputs do not follow (the board's safe outputs vent all).
TEST(FaultMonitor, TheBoardsOwnCutsAreBoardLimitNotASensorOrDriverFault) {
  EXPECT_EQ(flags_after_motor_commands(1.5, 0, true, true, true), 0u);
  EXPECT_TRUE(flags_after_motor_commands(1.5, 0, true, true, false) & safety::kFaultMotorDisagrees);  // the same without the report
  for (const bool follow : {true, false}) {
    MonitoredE1 e1;
    io::SensorState& state = e1.view.state;
    state.joints[0].agonist_loadcell_N = state.joints[0].antagonist_loadcell_N = 60.0;
    e1.view.check(e1.monitor, follow);
    EXPECT_EQ(e1.monitor.flags(), 0u);
    state.time_s = 1e-3;
    state.joints[0].board_limits = io::kBoardVentedAntagonist | io::kBoardMotorOff;
    e1.view.check(e1.monitor, follow);
    if (!follow) {
      EXPECT_EQ(e1.monitor.flags(), 0u);
      continue;
    }
    EXPECT_EQ(e1.monitor.flags(), safety::kFaultBoardLimit);
    EXPECT_EQ(e1.monitor.first().muscle, 1);
    EXPECT_EQ(e1.monitor.action(), safety::SafeAction::kDescend);
    EXPECT_NE(std::string(e1.monitor.run_reason()).find("board_limit joint 0 antagonist"), std::string::npos) << e1.monitor.run_reason();
  }
}

struct PressureRun {
  std::uint32_t flags = 0;
  double latched_at_s = -1;  ///< the first fault's time (-1: none)
};

/// E1's agonist held at a command of 0.1 MPa for 3 s while its sensor reads `offset_Pa` above it and,
/// from 1.5 s, rises by itself at `fill_Pa_per_s` (a valve filling with its command holding). With
/// `step_to_Pa` > 0 the command instead steps there at 1.5 s and the pressure follows as a valve twice
/// as slow as the model (the envelope's slow edge).
PressureRun run_pressure(double offset_Pa, double fill_Pa_per_s, std::uint32_t disabled = 0, double step_to_Pa = 0) {
  safety::MonitorParams p;
  safety::FaultMonitor monitor(p, 1e-3, {.unchecked = disabled});
  E1JointView view;
  io::SensorState& state = view.state;
  double command_Pa = 0.1e6, setpoint_Pa = 0.1e6, slow_Pa = 0.1e6;
  std::vector<double> commands;
  PressureRun run;
  for (int k = 0; k < 3000; ++k) {
    state.time_s = 1e-3 * k;
    const double noise = 0.01 * (k % 7);
    const double after_s = std::max(0.0, state.time_s - 1.5);
    if (step_to_Pa > 0 && after_s > 0) command_Pa = step_to_Pa;
    commands.push_back(command_Pa);
    // The slow valve: dead time 10 ms, rate 2 MPa/s, lag 60 ms.
    const double delayed = commands[static_cast<std::size_t>(std::max(0, k - 10))];
    setpoint_Pa += std::clamp(delayed - setpoint_Pa, -2000.0, 2000.0);
    slow_Pa += (1.0 - std::exp(-1e-3 / 0.06)) * (setpoint_Pa - slow_Pa);
    const double wobble_Pa = 300.0 * ((k * 7919) % 11 - 5) / 5.0;  // +-300 Pa, never repeating a code for long
    state.joints[0].agonist_pressure_Pa = slow_Pa + offset_Pa + fill_Pa_per_s * after_s + wobble_Pa;
    state.joints[0].antagonist_pressure_Pa = 0.1e6 + wobble_Pa;
    state.joints[0].agonist_loadcell_N = state.joints[0].antagonist_loadcell_N = 60.0 + noise;
    view.check(monitor, true);
    if (monitor.flags() && run.latched_at_s < 0) run.latched_at_s = monitor.first().time_s;
    io::Command c;
    c.joint_count = 1;
    c.joints[0].agonist_pressure_Pa = command_Pa;
    c.joints[0].antagonist_pressure_Pa = 0.1e6;
    monitor.sent(c);
  }
  run.flags = monitor.flags();
  return run;
}

// A pressure that rises by itself while the commands hold is a valve filling: pressure_rise (descend:
// sensor noise can trip it, docs/safety.md "False alarms"; pressure_high vents a valve that keeps filling) catches a 1 MPa/s fill about 14 cycles in, where the wide 60 kPa envelope check needs 63; a sensor's constant offset and a commanded step followed by a slow valve raise nothing.
TEST(FaultMonitor, APressureRisingWhileTheCommandsHoldIsRaisedLongBeforeTheEnvelopeTolerance) {
  const PressureRun fill = run_pressure(0.0, 1e6);
  EXPECT_TRUE(fill.flags & safety::kFaultPressureRise);
  EXPECT_EQ(safety::safe_action(safety::kFaultPressureRise), safety::SafeAction::kDescend);
  EXPECT_EQ(safety::safe_action(safety::kFaultPressureHigh), safety::SafeAction::kVent);
  EXPECT_GT(fill.latched_at_s, 1.5);
  EXPECT_LE(fill.latched_at_s, 1.5 + 0.016);
  // The broken supervisor without the rise check sees the same fill only at the 60 kPa tolerance
  // (the load cell, which does not follow this synthetic fill, is not judged here).
  const PressureRun without = run_pressure(0.0, 1e6, safety::kFaultPressureRise | safety::kFaultLoadcellStep | safety::kFaultLoadcellDisagrees);
  EXPECT_TRUE(without.flags & safety::kFaultPressureHigh);
  EXPECT_GE(without.latched_at_s, 1.5 + 0.060);
  constexpr std::uint32_t kPressureFlags = safety::kFaultPressureRise | safety::kFaultPressureHigh | safety::kFaultPressureLow;
  EXPECT_EQ(run_pressure(0.04e6, 0.0).flags, 0u);                              // a sensor offset of 40 kPa
  EXPECT_EQ(run_pressure(0.0, 0.0, 0, 0.3e6).flags & kPressureFlags, 0u);      // a commanded step, a slow valve
  // 50 kPa/s: the rise's level follows it (the envelope check judges it, at 60 kPa).
  EXPECT_EQ(run_pressure(0.0, 0.05e6).flags & safety::kFaultPressureRise, 0u);
}

/// The cycle at which encoder_disagrees latches (-1: never) while the joint turns at 10 deg/s from
/// 0.5 s, its encoder frozen at 0, the redundant encoder reading `redundant` (NaN: none) of the turn.
int encoder_disagrees_cycle(double redundant_gain, bool has_redundant = true) {
  MonitoredE1 e1;
  safety::FaultMonitor& monitor = e1.monitor;
  E1JointView& view = e1.view;
  io::SensorState& state = view.state;
  for (int k = 0; k < 1500; ++k) {
    state.time_s = 1e-3 * k;
    const double noise_N = 0.01 * (k % 7);
    state.joints[0].agonist_loadcell_N = state.joints[0].antagonist_loadcell_N = 60.0 + noise_N;
    const double turned_rad = models::deg_to_rad(std::max(0.0, state.time_s - 0.5) * 10.0);
    state.joints[0].angle_rad = 0.0;  // frozen
    state.joints[0].redundant_angle_rad = has_redundant ? redundant_gain * turned_rad : std::numeric_limits<double>::quiet_NaN();
    view.check(monitor, true);
    if (monitor.flags() & safety::kFaultEncoderDisagrees) return k;
  }
  return -1;
}

// The redundant joint-side encoder against the primary: a frozen encoder on a turning joint is
// raised once the two part by 2 deg (at 10 deg/s: 200 ms after the turn began, + 3 confirm cycles);
// two encoders within 2 deg (here the redundant one reads 10 % of the turn: 1 deg at the end), or
// no redundant encoder, raise nothing. Its safe state is hold: which encoder lies is unknown.
TEST(FaultMonitor, TwoEncodersOfOneJointThatPartAreRaisedAndHeld) {
  const int at = encoder_disagrees_cycle(1.0);
  EXPECT_GE(at, 700);
  EXPECT_LE(at, 704);
  EXPECT_EQ(safety::safe_action(safety::kFaultEncoderDisagrees), safety::SafeAction::kHold);
  EXPECT_EQ(encoder_disagrees_cycle(0.1), -1);
  EXPECT_EQ(encoder_disagrees_cycle(1.0, false), -1);
}

TEST(FaultMonitor, ADisconnectIsRaisedOnlyWhereAWireMayNotGoSlack) {
  EXPECT_TRUE(flags_after_a_taut_wire_reads_zero(true) & safety::kFaultLoadcellDisconnected);
  EXPECT_FALSE(flags_after_a_taut_wire_reads_zero(false) & safety::kFaultLoadcellDisconnected);
}

}  // namespace
}  // namespace peha

namespace peha {
namespace {

/// One row of the fault matrix (E1, 2.5 kg, 4 s: the link held still) for `kind`.
experiments::FaultRow matrix_row(experiments::E1Scenario s, sim::FaultKind kind, const std::string& moment = "holding") {
  experiments::FaultMatrixOptions o;
  o.kinds = {kind};
  o.moments = {moment};
  const std::vector<experiments::FaultRow> rows = experiments::run_fault_matrix(std::move(s), o);
  EXPECT_EQ(rows.size(), 2u);
  EXPECT_FALSE(rows.front().detected) << "false alarm in the nominal row: " << rows.front().flag;
  return rows.back();
}

experiments::E1Scenario e1() {
  return peha::test_support::shipped_e1();
}

// The descend safe state governs the link's speed with the carrying muscle (the agonist) and damps it
// with the motor: after a stuck load cell the link goes down at about the configured 11.5 deg/s, stops
// inside the range and no limit is exceeded; the wires keep some tension (measured 8.9 N: the model
// overestimates the agonist's force near its threshold, so its floor of half the held force is
// only a few N on the plant). Venting instead (the state the first supervisor chose for sensor
// faults) drops the loaded link to the stop: the same row exceeds the joint range at > 100 deg/s.
TEST(Descend, LowersTheLinkSlowlyAfterAStuckLoadCellWhereVentingDropsIt) {
  const experiments::FaultRow governed = matrix_row(e1(), sim::FaultKind::kLoadcellStuck);
  EXPECT_EQ(governed.safe_state, "descend");
  EXPECT_LE(governed.detection_cycles, governed.prompt_cycles);  // its window: loadcell_stuck_cycles (8)
  EXPECT_EQ(governed.limits_exceeded, 0);
  EXPECT_LE(governed.peak_speed_degps, 40.0);  // measured 34.8-36.2 (the first cycles); the descent itself ~12
  EXPECT_GT(governed.min_tension_N, 2.0);      // measured 8.9-9.1 (was 0.0 with the old bleed-both descent)
  EXPECT_TRUE(governed.physics_forbids.empty());

  experiments::E1Scenario wrong = e1();
  wrong.limits.test_overrides.vented = safety::kFaultLoadcellStuck;
  const experiments::FaultRow vented = matrix_row(wrong, sim::FaultKind::kLoadcellStuck);
  EXPECT_EQ(vented.safe_state, "vent");
  EXPECT_GE(vented.limits_exceeded, 1);  // the link leaves the range
  EXPECT_GT(vented.peak_speed_degps, 100.0);
}

// A joint running away (here: a +400 N load-cell bias that the controller's force trim turns into a
// falling link, with the load-cell step and drift checks off so that only the speed sees it) is caught by its
// speed (90 deg/s) and descends instead of holding: no limit exceeded. With the old 229 deg/s
// threshold and hold, the link reached the stop (1 limit).
TEST(Descend, ARunawayCaughtByItsSpeedIsBrakedInsideTheRange) {
  experiments::E1Scenario s = e1();
  s.limits.test_overrides.unchecked = safety::kFaultLoadcellStep | safety::kFaultLoadcellDrift;
  const experiments::FaultRow r = matrix_row(std::move(s), sim::FaultKind::kLoadcellBias);
  EXPECT_EQ(r.flag, "joint_speed");
  EXPECT_EQ(r.safe_state, "descend");
  EXPECT_EQ(r.limits_exceeded, 0);
  EXPECT_LE(r.peak_speed_degps, 120.0);  // measured 97
}

// The same +400 N bias with the step check on: the cell leaves the pressure model's company in one
// sample, and loadcell_step catches it in 3 cycles (confirm_cycles) where the speed check needed
// about 200 (holding) to 2000 (during a push) - the link never starts to fall.
TEST(FaultMatrix, ALoadCellBiasIsCaughtByItsStepBeforeTheLinkMoves) {
  const experiments::FaultRow r = matrix_row(e1(), sim::FaultKind::kLoadcellBias);
  EXPECT_EQ(r.flag, "loadcell_step");
  EXPECT_LE(r.detection_cycles, 5.0);
  EXPECT_EQ(r.safe_state, "descend");
  EXPECT_EQ(r.limits_exceeded, 0);
  EXPECT_LT(r.peak_speed_degps, 60.0);  // the descent's first cycles, not a fall (measured 36.4)
}

// Where no safe state can keep a limit (a wire breaks under load: 0 N whatever is commanded), the row
// says so with the reason; it is not counted as a miss of the designed outcome.
TEST(FaultMatrix, AWireBreakUnderLoadIsMarkedPhysicsForbids) {
  const experiments::FaultRow r = matrix_row(e1(), sim::FaultKind::kWireBreak);
  EXPECT_EQ(r.flag, "tension_floor");
  EXPECT_LE(r.detection_cycles, 5.0);
  EXPECT_GE(r.limits_exceeded, 1);
  EXPECT_NE(r.physics_forbids.find("0 N"), std::string::npos) << r.physics_forbids;
  EXPECT_TRUE(experiments::physics_forbids(sim::FaultKind::kLoadcellStuck).empty());
}

}  // namespace
}  // namespace peha

namespace peha {
namespace {

/// The pressures a hold fault (a controller NaN) holds after `vented_cycles` of a start-up vent
/// from 0.13 / 0.26 MPa, then `taut_cycles` with both wires taut at 0.20 / 0.10 MPa sent.
std::array<double, 2> held_after_a_nan(int vented_cycles, int taut_cycles) {
  safety::MonitorParams p;
  // Only the controller's NaN is checked: the synthetic pressures step where a valve would lag.
  safety::FaultMonitor monitor(p, 1e-3, {.unchecked = ~safety::kFaultNonFiniteCommand});
  E1JointView view;
  io::SensorState& state = view.state;
  io::Command sent;
  sent.joint_count = 1;
  int k = 0;
  auto cycle = [&](double ago_Pa, double ant_Pa, double cell_N) {
    state.time_s = 1e-3 * k++;
    state.joints[0].agonist_pressure_Pa = ago_Pa;
    state.joints[0].antagonist_pressure_Pa = ant_Pa;
    const double noise_N = 0.01 * (k % 7);
    state.joints[0].agonist_loadcell_N = cell_N + noise_N;
    state.joints[0].antagonist_loadcell_N = cell_N + noise_N;
    view.check(monitor, true);
    sent.joints[0] = {ago_Pa, ant_Pa, 0.0};
    monitor.sent(sent);
  };
  cycle(0.13e6, 0.26e6, 0.0);  // what the run finds: the limb held by these
  for (int i = 0; i < vented_cycles; ++i) cycle(0.0, 0.0, 0.0);
  for (int i = 0; i < taut_cycles; ++i) cycle(0.20e6, 0.10e6, 60.0);
  io::Command nan = sent;
  nan.joints[0].agonist_pressure_Pa = std::numeric_limits<double>::quiet_NaN();
  monitor.check_command(nan, state.time_s);
  EXPECT_EQ(monitor.action(), safety::SafeAction::kHold) << monitor.reason();
  monitor.shape(nan);
  return {nan.joints[0].agonist_pressure_Pa, nan.joints[0].antagonist_pressure_Pa};
}

// A fault while the start-up has the muscles vented on purpose must not hold the vent (vented
// muscles under a load drop it): it restores what held the limb when the run began. Once the
// controller carries the joint (both wires taut with the outputs following), the hold is the last
// command sent, as before.
TEST(FaultMonitor, AFaultDuringTheStartupVentHoldsThePressuresFoundNotTheVent) {
  const std::array<double, 2> startup = held_after_a_nan(500, 0);
  EXPECT_DOUBLE_EQ(startup[0], 0.13e6);
  EXPECT_DOUBLE_EQ(startup[1], 0.26e6);
  const std::array<double, 2> carried = held_after_a_nan(500, 1500);
  EXPECT_DOUBLE_EQ(carried[0], 0.20e6);
  EXPECT_DOUBLE_EQ(carried[1], 0.10e6);
}

}  // namespace
}  // namespace peha

namespace peha {
namespace {

/// Flags and action after `cycles` readings of `cell_N` on the agonist at 0.1 MPa measured (the
/// pressure model: a few hundred N), the wire taut at 60 N before.
std::pair<std::uint32_t, safety::SafeAction> after_over_ceiling(int cycles, double cell_N) {
  safety::MonitorParams p;
  safety::FaultMonitor monitor(p, 1e-3);
  feed_at_constant_pressure(monitor, 1500 + cycles, [&](int k, double noise_N) {
    return std::array<double, 2>{(k < 1500 ? 60.0 : cell_N) + noise_N, 60.0 + noise_N};
  });
  return {monitor.flags(), monitor.action()};
}

// A reading over the muscle's 2000 N ceiling that the pressure model cannot explain is first a
// load cell's fault (descend); held for force_ceiling_window_s (50 ms) it is a real over-force
// whatever the model says (a dead pressure sensor feeds the model) and vents. A 20 ms spike does not.
TEST(FaultMonitor, AReadingOverTheCeilingLongerThanItsWindowVentsWhateverTheModelSays) {
  const auto [held_flags, held_action] = after_over_ceiling(60, 2500.0);
  EXPECT_TRUE(held_flags & safety::kFaultLoadcellDisagrees);
  EXPECT_TRUE(held_flags & safety::kFaultForceCeiling);
  EXPECT_EQ(held_action, safety::SafeAction::kVent);
  const auto [spike_flags, spike_action] = after_over_ceiling(20, 2500.0);
  EXPECT_TRUE(spike_flags & safety::kFaultLoadcellDisagrees);
  EXPECT_FALSE(spike_flags & safety::kFaultForceCeiling);
  EXPECT_EQ(spike_action, safety::SafeAction::kDescend);
  // A full-scale reading is the saturated cell's, never vented by this window.
  EXPECT_FALSE(after_over_ceiling(200, 4995.0).first & safety::kFaultForceCeiling);
}

// The double fault of issue 29: a dead pressure sensor and a stuck-open valve on the carrying
// muscle. The load cell read 2740-2783 N for seconds under descend (the model, fed 0 MPa, could not
// agree); now the window vents it within about 0.1 s of passing 2000 N.
TEST(FaultMonitor, ADeadPressureSensorBehindAStuckOpenValveIsVentedWithinTheWindow) {
  experiments::E1Scenario s = short_e1();
  s.duration_s = 6.0;
  for (const char* spec : {"pressure_sensor_fail@4:agonist", "valve_stuck_open@4:agonist"}) {
    s.plant.faults.push_back(sim::parse_fault_spec(spec, sim::one_dof_rig_joint_names(), s.duration_s));
  }
  const experiments::E1Result r = experiments::run_e1_case(s, s.cases.back(), nullptr);
  EXPECT_TRUE(r.fault_flags & safety::kFaultForceCeiling) << r.fault_reason;
  EXPECT_LT(r.peak_muscle_force_N[0], 2800.0);  // measured 2695 N, over 2000 N for 0.12 s
}

}  // namespace
}  // namespace peha
