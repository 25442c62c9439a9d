#pragma once
/// \file
/// The supervisor's plausibility stage (docs/safety.md): every sample and every command that passes
/// safety::LimitedBackend - the one boundary between every controller and every backend, in process
/// and over UDP - is checked here. A failed check latches a named fault (FaultFlag) with its joint,
/// muscle, the value and the threshold, and chooses the designed safe state (SafeAction): hold,
/// descend below a configured joint speed, or vent. The latch clears only on the operator's recovery.
///
/// Checks per joint, on the sample (`check_sample`):
/// - load cell: disconnected (reads <= loadcell_disconnected_N), saturated (>= loadcell_saturated_N)
///   (both for confirm_cycles),
///   stuck (the same reading for loadcell_stuck_cycles), above the muscle's force ceiling (one
///   sample: acted on within the cycle), disagreeing with the pressure model (|reading -
///   F_model(P_measured, eps)| > tolerance_N + tolerance_fraction F_model for confirm_cycles);
/// - wire tension: the load cell below tension_floor_fraction x pretension for confirm_cycles, once
///   armed: the outputs have followed for tension_arm_s and the wire has been taut since (the
///   start-up tare's vent and a recovery ramp slacken the wires by design);
/// - pressure sensor against what the valve makes of the commands sent (dead time, rate limit,
///   first-order lag: the valve's dynamics, from the modelled valve to one valve_slow_factor x
///   slower: a worn or cold valve is not a fault), outside that envelope by more than
///   pressure_tolerance_Pa for confirm_cycles: high
///   (a valve filling by itself), low (a valve or sensor that does not follow; on two or more
///   muscles at once: supply loss), above supply; and, while the two valve models agree within
///   pressure_rise_Pa (the commands hold, so the valve should too), a rise of the pressure above the
///   envelope's upper edge by more than pressure_rise_Pa against its recent level, for confirm_cycles
///   (pressure_rise: a valve that fills by itself, seen long before it leaves the wide tolerance);
/// - encoder: a step above encoder_max_step_rad in one sample (jump), the same count for
///   encoder_frozen_cycles right after moving faster than encoder_frozen_speed_radps (frozen);
///   joint speed above max_joint_speed_radps, angle beyond the range by range_margin_rad; where the
///   joint has a redundant encoder on its axis (io::JointSensors::redundant_angle_rad finite), the
///   two angles apart by more than encoder_disagree_rad for confirm_cycles (encoder_disagrees: a
///   frozen, slipping or miscounting encoder, seen as soon as the joint has turned that far);
/// - supply (where the backend measures it: io::JointSensors::supply_pressure_Pa finite), for
///   confirm_cycles: below supply_lost_fraction x the joint's configured supply, supply_loss (hold:
///   no air to brake a descent with); below supply_low_fraction x, supply_low (descend on what is left);
/// - motor (where the backend measures it: io::JointSensors::motor_torque_Nm finite, a joint with a
///   motor): the driver's monitored torque outside the span of the commands sent over the last
///   motor_window_cycles (the link's latency: a sample may show any of them) by more than
///   motor_tolerance_Nm, for confirm_cycles (motor_disagrees: a dead driver, a broken motor lead);
/// - a non-finite sample;
/// - the board's own limits (io::JointSensors::board_limits): a muscle the board vented while the
///   outputs follow is board_limit (one sample: the board has acted already), never a sensor
///   fault; a motor the board cut is not judged by the motor check.
/// On the command (`check_command`): a non-finite value (the controller's NaN) - acted on in the
/// same cycle: the command that goes out is the safe one.
/// check_sample runs one small function per check family, always in the same order (a sample's first
/// raise is the fault it names). Each flag's name, safe state and threshold parameter are one row of
/// kChecks. While descending, check_sample also runs the descend governor of every governed
/// joint (descend_governor.hpp); shape() sends its command.
/// noexcept and allocation-free after construction.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"
#include "peha/safety/descend_governor.hpp"

#include <array>
#include <limits>
#include <bit>
#include <cstdint>

namespace peha::safety {

/// One value for every joint io::kMaxJoints allows.
constexpr std::array<bool, io::kMaxJoints> all_joints(bool value) noexcept {
  std::array<bool, io::kMaxJoints> a{};
  a.fill(value);
  return a;
}

enum FaultFlag : std::uint32_t {
  kFaultNonFiniteCommand = 1u << 0,
  kFaultNonFiniteSample = 1u << 1,
  kFaultForceCeiling = 1u << 2,
  kFaultLoadcellDisconnected = 1u << 3,
  kFaultLoadcellSaturated = 1u << 4,
  kFaultLoadcellStuck = 1u << 5,
  kFaultLoadcellDisagrees = 1u << 6,
  kFaultTensionFloor = 1u << 7,
  kFaultPressureHigh = 1u << 8,
  kFaultPressureLow = 1u << 9,
  kFaultSupplyLoss = 1u << 10,
  kFaultPressureOverSupply = 1u << 11,
  kFaultEncoderJump = 1u << 12,
  kFaultEncoderFrozen = 1u << 13,
  kFaultJointSpeed = 1u << 14,
  kFaultJointRange = 1u << 15,
  kFaultLoadcellStep = 1u << 16,
  kFaultEstop = 1u << 17,
  kFaultMotorDisagrees = 1u << 18,
  kFaultSupplyLow = 1u << 19,
  kFaultPressureRise = 1u << 20,
  kFaultEncoderDisagrees = 1u << 21,
  kFaultLoadcellZero = 1u << 22,
  kFaultBoardLimit = 1u << 23,
  kFaultLoadcellDrift = 1u << 24,
  kFaultDescentRunaway = 1u << 25,
};
inline constexpr int kFaultFlagCount = 26;

/// The designed safe states, mildest first (a later fault can only make the action stronger).
enum class SafeAction { kNone = 0, kHold = 1, kDescend = 2, kVent = 3 };

/// One check's row: its flag, the name logs and reasons use, its designed safe state, and the
/// MonitorParams field its threshold is made of ("" where no field sets it).
struct CheckInfo {
  FaultFlag flag;
  const char* name;
  SafeAction action;
  const char* parameter;
};

/// Every flag's row, at its bit's index; why each safe state: docs/safety.md.
inline constexpr std::array<CheckInfo, kFaultFlagCount> kChecks = {{
    // The controller cannot be trusted: keep what the muscles hold.
    {kFaultNonFiniteCommand, "nonfinite_command", SafeAction::kHold, ""},
    // Nothing to govern a descent with.
    {kFaultNonFiniteSample, "nonfinite_sample", SafeAction::kVent, ""},
    // Relieve the wire now (the threshold: the muscle's own ceiling, models::force_ceiling_N).
    {kFaultForceCeiling, "force_ceiling", SafeAction::kVent, ""},
    // Load-cell faults: the encoder still governs a slow descent.
    {kFaultLoadcellDisconnected, "loadcell_disconnected", SafeAction::kDescend, "loadcell_disconnected_N"},
    {kFaultLoadcellSaturated, "loadcell_saturated", SafeAction::kDescend, "loadcell_saturated_N"},
    {kFaultLoadcellStuck, "loadcell_stuck", SafeAction::kDescend, "loadcell_stuck_cycles"},
    {kFaultLoadcellDisagrees, "loadcell_disagrees", SafeAction::kDescend, "loadcell_tolerance_N"},  // + _fraction x the model
    // A broken or slipped wire.
    {kFaultTensionFloor, "tension_floor", SafeAction::kDescend, "tension_floor_fraction"},
    // A valve fills by itself: the dump valve vents past it.
    {kFaultPressureHigh, "pressure_high", SafeAction::kVent, "pressure_tolerance_Pa"},
    // A valve or sensor that does not follow.
    {kFaultPressureLow, "pressure_low", SafeAction::kDescend, "pressure_tolerance_Pa"},
    // The check valves keep the air; with no supply a descent cannot be braked.
    {kFaultSupplyLoss, "supply_loss", SafeAction::kHold, "supply_lost_fraction"},
    {kFaultPressureOverSupply, "pressure_over_supply", SafeAction::kVent, "pressure_over_supply_Pa"},
    // Encoder faults: no angle or speed to govern a descent with, and venting drops a loaded arm (the
    // fault matrix: 115-414 deg/s): keep what the muscles hold, motor off.
    {kFaultEncoderJump, "encoder_jump", SafeAction::kHold, "encoder_max_step_rad"},
    {kFaultEncoderFrozen, "encoder_frozen", SafeAction::kHold, "encoder_frozen_speed_radps"},
    // The governor brakes the motion and lowers the joint slowly.
    {kFaultJointSpeed, "joint_speed", SafeAction::kDescend, "max_joint_speed_radps"},
    // Back inside the range, then down to its end, slowly.
    {kFaultJointRange, "joint_range", SafeAction::kDescend, "range_margin_rad"},
    // A load-cell fault as the others.
    {kFaultLoadcellStep, "loadcell_step", SafeAction::kDescend, "loadcell_step_N"},
    // The hardware has already cut valves and motor (stop category 0).
    {kFaultEstop, "estop", SafeAction::kVent, ""},
    // The muscles keep what they hold, the motor is switched off.
    {kFaultMotorDisagrees, "motor_disagrees", SafeAction::kHold, "motor_tolerance_Nm"},
    // Air is left to brake with: lower the arm on it.
    {kFaultSupplyLow, "supply_low", SafeAction::kDescend, "supply_low_fraction"},
    // A valve that fills by itself, seen early - and the one pressure check sensor noise can trip
    // (10x noise: a false rise vented a loaded link): lower it governed; a valve that keeps filling
    // escalates to pressure_high (vent), a measured over-force to force_ceiling (vent).
    {kFaultPressureRise, "pressure_rise", SafeAction::kDescend, "pressure_rise_Pa"},
    // Which encoder lies is unknown: no angle to govern a descent with.
    {kFaultEncoderDisagrees, "encoder_disagrees", SafeAction::kHold, "encoder_disagree_rad"},
    // A load cell's power-on zero out of range (read vented, at start-up): the limb stays on its
    // support, the muscles keep what the run found.
    {kFaultLoadcellZero, "loadcell_zero", SafeAction::kHold, "loadcell_zero_max_N"},
    // The board vented a muscle on its own (its force ceiling or its range): the other muscle is
    // what is left to carry the limb, as the governor of a joint beyond its range uses.
    {kFaultBoardLimit, "board_limit", SafeAction::kDescend, ""},
    // A load cell whose zero creeps: the governor lowers the joint on the pressure model and the
    // encoder, which do not read the cell.
    {kFaultLoadcellDrift, "loadcell_drift", SafeAction::kDescend, "loadcell_drift_N"},
    // Descending, the joint keeps running down faster than the governor allows: the carrying muscle
    // cannot brake it, so the muscle that pulls the joint down is vented (the carrying one never is:
    // that would drop the limb); the governor and the motor keep braking.
    {kFaultDescentRunaway, "descent_runaway", SafeAction::kDescend, "descent_runaway_speed_radps"},
}};

/// The checks that judge the sensors and the hardware alone, whatever the run commands: a run that
/// drives the muscles far from their model, the joint to its stops and a wire near slack on purpose
/// (the calibration recording) keeps these and nothing else (a slack wire reads 0 N: not a
/// disconnected cell there).
inline constexpr std::uint32_t kHardwareChecks = kFaultNonFiniteCommand | kFaultNonFiniteSample | kFaultForceCeiling |
                                                 kFaultLoadcellSaturated | kFaultSupplyLoss |
                                                 kFaultPressureOverSupply | kFaultEncoderJump | kFaultEncoderFrozen | kFaultEstop |
                                                 kFaultEncoderDisagrees | kFaultBoardLimit;
inline constexpr std::uint32_t kAllChecks = (1u << kFaultFlagCount) - 1u;

/// Every flag has exactly one row, at its bit's index (fault_flag_name and safe_action index by bit).
constexpr bool checks_in_bit_order() noexcept {
  for (int i = 0; i < kFaultFlagCount; ++i) {
    if (kChecks[static_cast<std::size_t>(i)].flag != (1u << i)) return false;
  }
  return true;
}
static_assert(checks_in_bit_order(), "kChecks: one row per FaultFlag, in bit order");

const char* fault_flag_name(std::uint32_t single_flag) noexcept;  ///< "loadcell_stuck", ...
SafeAction safe_action(std::uint32_t single_flag) noexcept;
const char* safe_action_name(SafeAction a) noexcept;                ///< "hold", "descend", "vent"

/// Per check (at its flag's bit), the largest ratio of the quantity the check compares with its
/// threshold to that threshold: 1 = at the threshold (a check that must
/// fail confirm_cycles samples in a row trips only once the ratio stays above 1 that long). For a
/// check on a floor (tension, supply, a disconnected cell) the ratio is floor / value; for the range,
/// how far the angle is beyond the range / range_margin; over supply, the pressure's excess over the
/// supply / pressure_over_supply_Pa (a muscle at supply is 0); for a frozen encoder the smaller of its two
/// conditions' ratios; for a load cell's zero at code 0 (no magnitude), how much of its window the
/// code has lasted. 0: never evaluated (nonfinite, estop and checks of sensors a backend lacks).
/// Recorded while no fault is latched (what follows one is its safe state's, not fault-free running).
/// The false-alarm statistics (docs/safety.md "False alarms") are made of these.
using CheckPeaks = std::array<double, kFaultFlagCount>;

/// Thresholds (the scenario's optional `plausibility:` section; docs/safety.md).
struct MonitorParams {
  /// Checks a run switches off because it drives the muscles away from their model on purpose (the
  /// calibration recording: all but kHardwareChecks); every other check runs. No scenario sets it (a scenario
  /// cannot switch a check off: tests use CheckOverrides).
  std::uint32_t unmodelled = 0;
  /// A wire's slack and disconnect checks arm only once the outputs have followed the commands
  /// this long and the wire was taut since: start-up vents and recovery ramps slacken wires on purpose.
  double tension_arm_s = 1.0;
  /// A wire counts as taut (arming its slack checks) at this x pretension, above the floor: the
  /// hysteresis keeps a wire that refills slowly through the floor, with sensor noise, from arming
  /// and faulting at once (robustness sensor_noise_x3: the antagonist at 16-18 N around 1.03 s).
  double tension_taut_fraction = 0.5;
  /// Start-up: a wire of a tension-checked joint never taut and below the floor this long after the
  /// outputs began to follow (a broken or unhooked wire) latches tension_floor before the limb leaves
  /// its support.
  double tension_taut_deadline_s = 5.0;
  /// Start-up: a load cell reading beyond this while the pressure model says its muscle makes no
  /// force (vented) for loadcell_zero_confirm_s: its zero is off (a -300 N offset drove E1 to 50 deg).
  double loadcell_zero_max_N = 100.0;
  double loadcell_zero_confirm_s = 0.1;
  /// A reading over the muscle's ceiling this long vents whatever the pressure model says (the model
  /// may be fed by a dead sensor); shorter readings the model cannot explain are a cell's (descend).
  double force_ceiling_window_s = 0.05;  ///< longer than the vent's transient (the force lags the pressure)
  int confirm_cycles = 3;                     ///< consecutive samples a noisy check must fail
  double loadcell_disconnected_N = 0.01;      ///< at or below: AD code 0
  double loadcell_saturated_N = 4990.0;       ///< at or above: the channel's full scale
  /// The same reading this often: stuck (a live cell has noise). Two successive readings of a cell
  /// with 1 N of noise on a 16-bit 0-5000 N channel are equal with p = 0.021, so n equal readings
  /// happen by chance with p^(n-1) per cycle: 5 gave a false alarm about every 40 min of holding at
  /// 1 kHz (two cells), 8 once in about 10^5 h.
  int loadcell_stuck_cycles = 8;
  /// |cell - model| may reach this + loadcell_tolerance_fraction x the model's force. The fraction:
  /// the model's error grows with the force (fault-free E1 came to 0.68 x, a muscle 15 % weaker to
  /// 0.75 x, of 300 N + 0.6 F); the constant stays below a +400 N bias at the start-up's small forces.
  double loadcell_tolerance_N = 300.0;
  double loadcell_tolerance_fraction = 0.75;
  /// A load cell that jumps away from the pressure model: |(cell - model) - its recent level| above
  /// this for confirm_cycles (a bias, a slipping clamp, a broken cell). The recent level follows the
  /// disagreement with a time constant of loadcell_step_filter_s, so the model's slow errors pass.
  double loadcell_step_N = 100.0;
  double loadcell_step_filter_s = 0.05;
  /// The disagreement is low-passed with this before it is compared: the pressure model turns the
  /// pressure sensor's noise into force noise (about 17 N per kPa on E1's agonist), and unfiltered
  /// the step reached 1.0-1.3 x its threshold with 3x sensor noise (docs/safety.md "False alarms").
  double loadcell_step_noise_filter_s = 0.003;
  /// loadcell_drift: a cell's zero that creeps (too slowly for the step check, inside the
  /// disagreement tolerance for tens of seconds). The disagreement (cell - model), low-passed with
  /// loadcell_drift_filter_s, is summed over the samples its joint has been still (below
  /// loadcell_drift_still_radps) for loadcell_drift_settle_s - a muscle relaxes after it stops, and
  /// its model error moves with the operating point while it moves - in both directions, each sum
  /// leaking loadcell_drift_leak_N_per_s of stillness (a two-sided CUSUM); either above
  /// loadcell_drift_N: drift. The sums run across still spans (E1's link is pushed every ~9 s) and
  /// restart only when the joint is not carried. Nor do samples count while the muscle's force by
  /// the model moves faster than loadcell_drift_max_rate_N_per_s (the model's error moves with the
  /// force: E5's clamped ramp at hundreds of N/s tripped it); a creeping zero that the force trim
  /// follows moves the model force at about its own rate.
  double loadcell_drift_N = 80.0;
  double loadcell_drift_max_rate_N_per_s = 30.0;
  double loadcell_drift_filter_s = 0.5;
  double loadcell_drift_settle_s = 0.5;
  double loadcell_drift_arm_s = 2.0;  ///< the sums start this long after the joint is carried (the refill's tail)
  double loadcell_drift_still_radps = 0.0175;  ///< 1 deg/s
  double loadcell_drift_leak_N_per_s = 0.5;
  double tension_floor_fraction = 0.3;        ///< of the joint's pretension: a wire near slack (the verdict judges 0.5)
  /// pressure_high / pressure_low: the pressure beyond the envelope by this. pressure_high (vent)
  /// compares the excess low-passed with pressure_rise_filter_s: unfiltered, 10x sensor noise took it
  /// to 0.86 x this on fault-free runs (docs/safety.md "False alarms").
  double pressure_tolerance_Pa = 0.06e6;
  double pressure_over_supply_Pa = 0.05e6;    ///< measured above supply by more than this
  /// pressure_rise: while the modelled and the slow valve agree within this, the pressure's excess
  /// over the envelope's upper edge (max(0, P - upper edge), low-passed with pressure_rise_filter_s)
  /// may rise at most this much above its recent level (low-passed with loadcell_step_filter_s).
  /// 8 kPa: 6 sigma of the filtered excess with 3x the pressure sensors' 1 kPa noise; a sensor's
  /// offset is in the level and passes.
  double pressure_rise_Pa = 0.008e6;
  double pressure_rise_filter_s = 0.003;
  double valve_dead_time_s = 0.005;           ///< the valve's dynamics as the supervisor models them
  double valve_lag_s = 0.03;
  double valve_rate_Pa_per_s = 4e6;
  /// The envelope's slow edge: dead time and lag x this, rate limit / this (>= 1; 1: the model alone).
  double valve_slow_factor = 2.0;
  /// The envelope's fast edge: dead time and lag x this, rate limit / this (<= 1; 1: the model alone).
  /// A valve twice as fast as the model led it by 0.91 x the tolerance on the arm (valve_fast_x0.5).
  double valve_fast_factor = 0.5;
  double encoder_max_step_rad = 0.02;
  int encoder_frozen_cycles = 5;
  double encoder_frozen_speed_radps = 0.2;
  /// The encoder and the redundant joint-side encoder may differ by this much (the gear's backlash
  /// and the two resolutions), rad: 2 deg.
  double encoder_disagree_rad = 0.0349;
  double max_joint_speed_radps = 1.57;        ///< 90 deg/s: a falling link (nominal runs peak below 40)
  double range_margin_rad = 0.08;
  /// The range judged ahead (as the board's range vent): the angle led by its filtered speed x
  /// range_lead_s (the valves' reaction) plus the distance range_brake_radps2 takes to stop it.
  /// A joint falling toward its stop faster than it can still be stopped is caught before the stop,
  /// not on it: an elbow whose load cell crept let it fall from 88 deg onto its stop at 327 deg/s,
  /// 2.2 deg into it; led, it is caught at 282 deg/s inside its range. 0 / inf: the angle alone.
  /// Only a `governed` joint is led: the others (the wrist) are stopped by their own muscles' spring.
  double range_lead_s = 0.035;  ///< the valves' dead time and lag (5 + 30 ms)
  double range_brake_radps2 = 34.9;  ///< 2000 deg/s^2
  /// The supply sensor below this x the configured supply: supply_low (0.6: the half supply of a
  /// failing compressor is caught; a plant capped at 0.6 of it still is not a fault).
  double supply_low_fraction = 0.6;
  /// Below this x the configured supply: supply_loss. The descend governor brakes by adding air, so
  /// without supply it cannot: such a loss holds (E1's push with no supply fell at 160 deg/s descending).
  double supply_lost_fraction = 0.25;
  /// The motor driver's monitored torque may differ from the command by this much (the monitor's
  /// resolution and noise, the driver's current loop within a cycle), Nm.
  double motor_tolerance_Nm = 0.25;
  /// A sample shows the torque of one of the commands sent over this many cycles (the link's
  /// latency: the board emulator's 3 ms delay shows commands 3-4 cycles old). At most kMotorWindow.
  int motor_window_cycles = 10;
  // The descend safe state (docs/safety.md): a speed governor on the carrying muscle's force (the
  // pressure model turns it into a pressure), the motor a damper, the other muscle held.
  double descent_speed_radps = 0.2;           ///< the joint descends at this speed, never much faster
  double descent_force_rate_N_per_s = 150.0;  ///< how fast the carrying force is bled while the joint does not descend
  double descent_gain_N_per_radps = 600.0;    ///< force added per rad/s the joint descends too fast (proportional)
  double descent_floor_fraction = 0.5;        ///< the bled force never below this x the force held at the fault
  /// The carrying force rises at most this fast, N/s, so that the governor brakes a joint the
  /// operator is moving without a jolt. Default: no limit (the one-DOF link has nothing distal to
  /// whip, and a slower rise let a push reach 55-75 deg/s instead of 47). The arm sets 2000: an
  /// unlimited step of 600 N per rad/s at the shoulder whipped the wrist to 145 deg/s.
  double descent_force_slew_N_per_s = 1e6;
  double descent_damping_Nms_per_rad = 5.0;   ///< motor torque = -this x joint speed (within the rating)
  /// On a joint with no fault of its own, each muscle's force is trimmed toward the governor's by its
  /// load cell at this rate (1/s; DescendGovernorModel::trim_rate_per_s). 0, the pressure model alone,
  /// by default: at 5 /s the upper body's fault matrix went from 3 misses to 20 (docs/safety.md).
  double descent_trim_rate_per_s = 0.0;
  double descent_lifted_bleed_fraction = 0.2;  ///< DescendGovernorModel::lifted_bleed_fraction
  double descent_stop_margin_rad = 0.0873;    ///< the descent stops this far inside the range's lower end (5 deg)
  double speed_filter_Hz = 15.0;              ///< low-pass of the encoder's finite difference the governor reads
  /// Descending, the joint moving down (toward the end the carrying muscle lets it go to) faster than
  /// this for descent_runaway_window_s does not slow: descent_runaway vents the muscle that pulls it
  /// down. The window: longer than an operator's brisk push down during a descent (E1: 0.11 s above 30 deg/s).
  double descent_runaway_speed_radps = 0.5236;  ///< 30 deg/s
  double descent_runaway_window_s = 0.3;
  std::array<bool, io::kMaxJoints> tension_checked = all_joints(true);  ///< per joint
  /// Per joint: the descend safe state governs it (false: it keeps the pressures held at the fault -
  /// a constant-pressure joint such as the arm's wrist, whose held pressures are its design; governed,
  /// the light wrist swung at 64-381 deg/s in the fault matrix).
  std::array<bool, io::kMaxJoints> governed = all_joints(true);
};

/// A deliberately broken supervisor: what a test or benchmark changes in the designed one, to show
/// what the designed one is needed for (its fault-matrix row fails with the change). Not part of a
/// scenario: no YAML key sets it, MonitorParams does not hold it; the default changes nothing.
struct CheckOverrides {
  std::uint32_t unchecked = 0;  ///< FaultFlag bits not checked
  std::uint32_t vented = 0;     ///< FaultFlag bits whose safe state is vent instead of their kChecks row's
  /// The descend governor's old integral, which bled the carrying force also while someone lifted the
  /// joint (the elbow's flexor fell to 1.0-2.5 N under an operator flexing it).
  bool governor_bleeds_while_lifted = false;
};

/// Reads the scenario root's optional `plausibility:` section (the old name `supervisor:` is refused, naming it) into `p` (keys absent keep their
/// defaults; unknown keys and out-of-range values throw config::Error). Does not finish `root`.
void read_monitor_params(config::Map& root, MonitorParams& p);

/// The first fault of a run (or since the last recovery), for logs, console and fault dump.
struct FaultRecord {
  std::uint32_t flag = 0;
  int joint = -1;
  int muscle = -1;  ///< 0 agonist, 1 antagonist, -1 the joint
  double value = 0;
  double threshold = 0;
  double time_s = 0;
  std::uint64_t sample = 0;  ///< the sample's sequence number
};

class FaultMonitor {
 public:
  static constexpr int kMaxDelay = 64;  ///< valve dead time in cycles, at most
  static constexpr int kMotorWindow = 16;  ///< commands kept for the motor check, at most
  static constexpr double kZeroChange_N = 1.0;  ///< a declared zero that moves more re-judges the wire

  /// `overrides`: the designed supervisor (default) or a test's broken one (CheckOverrides).
  FaultMonitor(const MonitorParams& params, double period_s, const CheckOverrides& overrides = {}) noexcept
      : params_(params),
        overrides_(overrides),
        period_s_(period_s),
        per_period_(per_period(params, period_s)),
        governor_(governor_model(params, period_s, overrides)) {}

  /// Checks a new sample against the joint set-ups and the angle range.
  void check_sample(const io::SensorState& s, const std::array<const models::JointModel*, io::kMaxJoints>& joints,
                    const std::array<double, io::kMaxJoints>& min_angle_rad, const std::array<double, io::kMaxJoints>& max_angle_rad,
                    bool outputs_follow) noexcept;
  /// Checks a command from the controller (before it is shaped); true when it is usable.
  bool check_command(const io::Command& c, double t_s) noexcept;
  /// The command sent (after limits): the valve model's input for the next samples.
  void sent(const io::Command& c) noexcept;
  /// The safe state's command (hold: the last command before the fault, motor off; descend: the
  /// governor's, computed on the newest sample by check_sample). Leaves `c` alone otherwise.
  void shape(io::Command& c) const noexcept;
  /// After the limits (whose pressure floor keeps every wire's pretension): the muscles
  /// descent_runaway vents, at 0 Pa. Leaves every other value alone.
  void vent_escalated(io::Command& c) const noexcept;

  SafeAction action() const noexcept { return action_; }
  std::uint32_t flags() const noexcept { return flags_; }  ///< every latched FaultFlag
  const FaultRecord& first() const noexcept { return first_; }
  /// "loadcell_stuck joint 0 agonist: 812.3 (threshold 5) at 3.004 s -> descend" (fixed buffer).
  const char* reason() const noexcept { return reason_; }
  std::uint64_t count() const noexcept { return count_; }  ///< faults latched over the run
  /// The run's first fault as reason() gave it (kept across recoveries; empty before any fault).
  const char* run_reason() const noexcept { return run_reason_; }
  /// Whether what goes out is the controller's own command (runtime::run_cycles, every cycle, from the
  /// supervisor): not while a fault holds the outputs nor while a recovery ramps them from the
  /// measured pressures - the muscles are refilling then, taut wires carry no load yet (let go at
  /// 30 % of the ramp, E1's link fell at 118 deg/s). Not ready() meanwhile.
  void controller_in_command(bool in_command) noexcept { controller_in_command_ = in_command; }
  /// The operator's recovery: the latch clears, the valve model restarts from the measured pressures.
  void clear() noexcept;
  const MonitorParams& params() const noexcept { return params_; }
  /// Every check's largest ratio to its threshold while no fault was latched (CheckPeaks).
  const CheckPeaks& peaks() const noexcept { return peaks_; }
  /// Joint `j` is carried: both wires taut with the outputs following (the start-up is over).
  bool carried(int j) const noexcept { return j >= 0 && j < io::kMaxJoints && joints_[static_cast<std::size_t>(j)].carried; }
  /// The run is ready for the operator to let go of the limb (docs/safety.md "Start-up"): no fault
  /// shown, the controller's own command going out (controller_in_command), and joints
  /// 0..joint_count-1 all carried.
  bool ready(int joint_count) const noexcept {
    if (flags_ != 0 || !controller_in_command_) return false;
    for (int j = 0; j < joint_count; ++j) {
      if (!carried(j)) return false;
    }
    return true;
  }

  /// The backend reports an e-stop (its input line, the board's status, or estop()): latched as the
  /// flag `estop` at the sample's time, so that logs, verdicts and the fault matrix name it.
  void estop_reported() noexcept { raise(kFaultEstop, -1, -1, 1.0, 0.0); }

 private:
  void raise(std::uint32_t flag, int joint, int muscle, double value, double threshold) noexcept;
  /// The check of `flag` compared a quantity at `ratio` x its threshold (peaks()).
  void observe(std::uint32_t flag, double ratio) noexcept {
    if (flags_) return;  // a safe state's own motion is no statistic of fault-free running
    double& peak = peaks_[static_cast<std::size_t>(std::countr_zero(flag))];
    if (ratio > peak) peak = ratio;  // false for NaN
  }
  bool on(std::uint32_t flag) const noexcept { return !((overrides_.unchecked | params_.unmodelled) & flag); }

  struct MuscleState {
    double last_loadcell_N = -1;
    int same_loadcell = 0;
    int disconnected = 0, saturated = 0;
    bool taut = false;  ///< the wire was above the tension floor since the outputs began to follow
    double zero_N = 0;  ///< the zero the controller subtracts from this cell (check_command)
    double cell_level_N = 0;  ///< the cell low-passed with loadcell_step_filter_s (less zero_N: arms taut)
    bool has_cell_level = false;
    int disagree = 0, low_tension = 0, pressure_low = 0, pressure_high = 0;
    std::array<double, kMaxDelay> delay{};
    int head = 0;
    double setpoint_Pa = 0, predicted_Pa = 0;            ///< the modelled valve
    double slow_setpoint_Pa = 0, slow_predicted_Pa = 0;  ///< the envelope's slow valve
    double fast_setpoint_Pa = 0, fast_predicted_Pa = 0;  ///< the envelope's fast valve
    double disagreement_level_N = 0;  ///< low-passed (cell - model) for the step check
    double disagreement_fast_N = 0;   ///< (cell - model) low-passed with loadcell_step_noise_filter_s
    bool has_level = false;
    int step = 0;
    int zero_off = 0;  ///< consecutive vented samples with the cell beyond loadcell_zero_max_N
    int never_taut = 0;    ///< consecutive samples past tension_taut_deadline_s below the floor, never taut
    int over_ceiling = 0;  ///< consecutive readings over the muscle's ceiling (below full scale)
    double excess_fast_Pa = 0, excess_level_Pa = 0;  ///< the rise check's filtered excess and its level
    double above_fast_Pa = 0;  ///< the pressure above the envelope low-passed with pressure_rise_filter_s (pressure_high)
    bool has_excess = false;
    int rise = 0;
    double drift_fast_N = 0, drift_last_N = 0;  ///< the drift check's filtered disagreement and its last counted value
    double drift_up_N = 0, drift_down_N = 0;    ///< its two sums (CUSUM)
    /// The model's force low-passed with loadcell_drift_filter_s and with 4 x that: on a ramp of r N/s
    /// they part by r x 3 x loadcell_drift_filter_s (the rate gate, without a noisy derivative).
    double drift_model_fast_N = 0, drift_model_slow_N = 0;
    bool has_drift = false;
    /// pressure_low latched on this muscle: its valve or sensor does not follow, so a pressure it keeps
    /// while the commands fall past it (a stuck-closed valve under the governor's bleed) is the same
    /// fault, not a valve that fills (pressure_high is not judged; force_ceiling still is).
    bool not_following = false;
  };
  struct JointState {
    std::array<MuscleState, 2> muscle{};
    double last_angle_rad = 0, last_change_speed_radps = 0, last_change_t_s = 0, last_t_s = 0, speed_radps = 0;
    double filtered_speed_radps = 0;
    double still_s = 0;  ///< how long the filtered speed has stayed below loadcell_drift_still_radps
    double carried_since_s = 0;  ///< when `carried` last became true
    double follow_since_s = -1;  ///< when the outputs began to follow (< 0: they do not)
    int same_angle = 0;
    int encoder_apart = 0;  ///< consecutive samples the two encoders disagree
    int runaway = 0;        ///< consecutive descending samples faster than descent_runaway_speed_radps
    int supply_low = 0, supply_lost = 0, motor_off = 0;  ///< consecutive samples failing the supply and motor checks
    /// The motor torque of the commands sent while the outputs followed, a ring of the last
    /// kMotorWindow (newest at motor_head; motor_sent counts them, up to kMotorWindow).
    std::array<double, kMotorWindow> sent_motor_Nm{};
    int motor_head = 0, motor_sent = 0;
    bool has_previous = false;
    /// The pressures measured on the joint's first sample and on every sample while the outputs do
    /// not follow: what holds the limb while the run does not (before arming, after an outage). A
    /// fault before the joint is `carried` holds (and descends from) these, not the start-up's vent
    /// nor the commands sent before an outage: vented muscles under a load drop it, stale ones
    /// launch it.
    std::array<double, 2> found_Pa{};
    bool has_found = false;
    /// Both wires have been taut with the outputs following (the controller carries the joint);
    /// cleared while the outputs do not follow (an outage, a disarmed board).
    bool carried = false;
    DescendGovernorData governor{};
  };
  struct MuscleSample;  ///< one muscle of one sample and what its checks derive from it (fault_monitor.cpp)
  /// `followed_s`: how long the joint's outputs have followed the commands (< 0: they do not).
  inline MuscleSample muscle_sample(int j, int m, const io::JointSensors& in, const models::JointModel& model, const JointState& js,
                                    double followed_s) const noexcept;

  // The check families, in the order check_sample runs them (their raises name a sample's first fault).
  // Inline: each has one caller, in fault_monitor.cpp, and folds back into it (no call per check per sample).
  inline bool check_finite(int j, const io::JointSensors& in) noexcept;
  inline void check_encoder(int j, const io::JointSensors& in, double t_s, JointState& js) noexcept;
  inline void check_speed(int j, const JointState& js) noexcept;
  inline void check_frozen(int j, double step_rad, double dt_s, double t_s, JointState& js) noexcept;
  inline void check_redundant_encoder(int j, const io::JointSensors& in, JointState& js) noexcept;
  inline void check_range(int j, double angle_rad, double speed_radps, double min_angle_rad, double max_angle_rad) noexcept;
  inline void check_board_limits(int j, const io::JointSensors& in, bool outputs_follow) noexcept;
  inline void check_supply(int j, const io::JointSensors& in, const models::JointModel& model, JointState& js) noexcept;
  inline void check_motor(int j, const io::JointSensors& in, const models::JointModel& model, bool outputs_follow, JointState& js) noexcept;
  inline bool check_muscle(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_load_cell(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_tension_floor(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_startup(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_load_cell_step(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_load_cell_drift(const MuscleSample& x, MuscleState& ms) noexcept;
  inline bool check_valve(const MuscleSample& x, MuscleState& ms) noexcept;
  inline void check_pressure_rise(const MuscleSample& x, double above_Pa, MuscleState& ms) noexcept;
  inline void check_low_pressures(int low_muscles, int joint_count) noexcept;
  void govern(const io::SensorState& s, const std::array<const models::JointModel*, io::kMaxJoints>& joints,
              const std::array<double, io::kMaxJoints>& min_angle_rad, const std::array<double, io::kMaxJoints>& max_angle_rad) noexcept;

  /// What the thresholds and the period fix for every sample: the valve models' dead times in cycles
  /// and the first-order filters' factors per period (derived once, not per sample).
  struct PerPeriod {
    int delay_cycles = 0, slow_delay_cycles = 0, fast_delay_cycles = 0;
    double valve_alpha = 0, slow_valve_alpha = 0, fast_valve_alpha = 0, step_alpha = 0, step_fast_alpha = 0, rise_alpha = 0, drift_alpha = 0, drift_slow_alpha = 0;
    int zero_cycles = 0;          ///< loadcell_zero_confirm_s (also the never-taut wire's), at least confirm_cycles
    int runaway_cycles = 0;       ///< descent_runaway_window_s, at least 1
    int over_ceiling_cycles = 0;  ///< force_ceiling_window_s, at least 1
  };
  static PerPeriod per_period(const MonitorParams& p, double period_s) noexcept;
  static DescendGovernorModel governor_model(const MonitorParams& p, double period_s, const CheckOverrides& o) noexcept;

  MonitorParams params_;
  CheckOverrides overrides_;
  double period_s_;
  PerPeriod per_period_;
  DescendGovernorModel governor_;
  std::array<JointState, io::kMaxJoints> joints_{};
  bool synced_ = false;
  bool controller_in_command_ = true;  ///< controller_in_command: what goes out is the controller's own command
  SafeAction action_ = SafeAction::kNone;
  std::uint32_t flags_ = 0;
  std::uint32_t faulted_joints_ = 0;  ///< bit j: a raise has named joint j (its cells are not trusted by the governor)
  FaultRecord first_{};
  double t_s_ = 0;
  std::uint64_t sequence_ = 0, count_ = 0;
  CheckPeaks peaks_{};
  io::Command held_{};       ///< the last command sent before the fault, or what start-up found (hold)
  io::Command last_sent_{};
  char reason_[160] = {};
  char run_reason_[160] = {};
};

}  // namespace peha::safety
