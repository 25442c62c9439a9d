#pragma once
/// \file
/// Experiment E3 "postures" on an arm or both arms: the operator moves the arms with the user to
/// several postures and lets go; with gravity compensation tau = J^T G and no position feedback they
/// should stay where they were left. The figures, per gravity-compensated joint and posture: drift
/// over observe_s after each release, excursion, distance to a stop, static torque error.

#include "peha/hardware/door.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/runtime/lifecycle.hpp"

#include <string>
#include <vector>

namespace peha::experiments {

/// One gravity-compensated joint's figures after one release.
struct PostureJointResult {
  std::string joint;                  ///< io joint name, e.g. "R_SFE"
  double target_deg = 0;              ///< where the operator aimed (NaN: left free)
  double released_deg = 0;            ///< where the joint was at release (plant truth, else encoder)
  double drift_deg = 0;               ///< angle observe_s after release minus at release
  double max_excursion_deg = 0;
  double stop_distance_deg = 0;       ///< closest to either end of the joint's range after release
  /// In simulation (plant truth): the torque the friction and stops hold at rest, averaged over the
  /// last second of the window, as % of the gravity torque the joint carries there (NaN without truth).
  double static_torque_error_pct = 0;
  double gravity_torque_Nm = 0;
  /// The controller's gravity torque (its J^T G) minus the plant's, as % of the plant's, over the same
  /// second: the part of the static error no feed-forward can remove (NaN without truth).
  double model_gravity_error_pct = 0;
};

struct PostureResult {
  std::string name;
  std::vector<PostureJointResult> joints;  ///< every gravity-compensated io joint, in io order
};

struct PosturesResult {
  std::vector<PostureResult> postures;
  double peak_muscle_force_N = 0;     ///< any muscle, plant truth
  double min_wire_tension_N = 0;      ///< any wire, plant truth
  double peak_operator_torque_Nm = 0;
  double realtime_factor = 0;
  /// The safety envelope's checks (safety/verdict.hpp) and, per posture and joint, |drift| and the
  /// distance to a stop against the scenario's `verdict:` thresholds.
  safety::Verdict verdict;
  bool within_limits = false;         ///< verdict.passed()
  std::uint64_t faults = 0;           ///< faults the supervisor's plausibility stage latched (a faulted run fails)
  std::uint32_t fault_flags = 0;      ///< safety::FaultFlag bits latched at the end
  std::string fault_reason;           ///< the first fault: flag, joint, muscle, value, threshold, time, safe state
  safety::CheckPeaks check_peaks{};   ///< every check's largest ratio to its threshold (FaultMonitor::peaks)
  std::uint32_t first_fault_flag = 0;  ///< the run's first latched FaultFlag (0: none; FaultMonitor::first)
  /// The run's lifecycle transitions (runtime::Supervisor: the link's faults, the recoveries), oldest first.
  std::vector<runtime::LifecycleEvent> lifecycle;
};

/// The joints E3 judges: every io joint in gravity mode (not the constant-pressure holds), in io order.
std::vector<std::size_t> gravity_joints(const ArmScenario& scenario);

/// The per-cycle log's columns: t_s, operator_active, then per io joint its block (prefixed with the
/// joint's log name, arm_log_prefix), limit_flags, fault_flags. Each block holds every sensor the
/// controller read (hardware::kSensorColumns), so the log can be replayed (`--backend replay:`).
std::vector<std::string> arm_log_columns(const ArmScenario& scenario);
/// "sfe" for the single arm's R_SFE, "r_sfe" / "l_sfe" on a two-armed body.
std::string arm_log_prefix(const ArmScenario& scenario, std::size_t io_joint);

/// What an arm run declares to the hardware door (hardware::open_backend): the io joints, the
/// scenario's period and mfb: section, the simulated arm `plant` (sim:), each joint's log prefix
/// (replay:). `one_board`: the run's board-side inputs live on one board (E4's goniometer).
hardware::HardwareRequest arm_hardware(const ArmScenario& scenario, const sim::ArmPlantParams& plant, bool one_board = false);

/// What E3 declares to the hardware door: arm_hardware with the simulated arm of E3's script
/// (postures_plant_params) for sim:.
hardware::HardwareRequest postures_hardware(const ArmScenario& scenario);

/// E3 on the in-process simulated arm (the door's sim:). `log` (optional) gets one row per control cycle.
PosturesResult run_postures(const ArmScenario& scenario, runtime::RowSink* log);

/// The simulated arm of E3: the scenario's plant with the operator's script (hold at the start,
/// then carry the arm to each posture, hold, let go) - also what `peha mfb-emulator` simulates.
sim::ArmPlantParams postures_plant_params(const ArmScenario& scenario);
/// When the operator lets go of each posture, s (E3's script), and the run's length (the whole
/// script, or up to scenario.postures_stop_s when that is set).
std::vector<double> postures_release_times_s(const ArmScenario& scenario);
double postures_duration_s(const ArmScenario& scenario);

/// E3 on any backend. `sim` (optional) is the in-process arm when `backend` is it (truth figures);
/// without it the drift comes from the joint encoders, forces and tensions from the load cells, and
/// the operator is where the script puts them. A cycle whose read() fails holds the last command.
PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, sim::ArmBackend* sim, runtime::RowSink* log,
                               const runtime::CycleHooks& hooks = {});

}  // namespace peha::experiments
