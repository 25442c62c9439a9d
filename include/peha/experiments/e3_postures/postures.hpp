#pragma once
/// \file
/// Experiment E3 "postures" on the right arm: the operator moves the arm with its mannequin to
/// several postures and lets go; with gravity compensation tau = J^T G and no position feedback it
/// should stay where it was left. The figures are the drift of shoulder and elbow over observe_s
/// after each release.

#include "peha/experiments/right_arm/arm_scenario.hpp"

#include <string>
#include <vector>

namespace peha::experiments {

struct PostureResult {
  std::string name;
  double target_deg[2] = {0, 0};      ///< SFE, EFE the operator aimed at
  double released_deg[2] = {0, 0};    ///< where the arm was at release (plant truth)
  double drift_deg[2] = {0, 0};       ///< angle observe_s after release minus at release
  double max_excursion_deg[2] = {0, 0};
  double stop_distance_deg[2] = {0, 0};  ///< closest to either end of the joint's range after release
  /// In simulation (plant truth): the torque the friction and stops hold at rest, averaged over the
  /// last second of the window, as % of the gravity torque the joint carries there (NaN without truth).
  double static_torque_error_pct[2] = {0, 0};
  double gravity_torque_Nm[2] = {0, 0};
  /// The controller's gravity torque (its J^T G) minus the plant's, as % of the plant's, over the same
  /// second: the part of the static error no feed-forward can remove (NaN without truth).
  double model_gravity_error_pct[2] = {0, 0};
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
};

const std::vector<std::string>& arm_log_columns();

/// E3 on the in-process simulated arm. `log` (optional) gets one row per control cycle.
PosturesResult run_postures(const ArmScenario& scenario, runtime::RowSink* log);

/// The simulated arm of E3: the scenario's plant with the operator's script (hold at the start,
/// then carry the arm to each posture, hold, let go) - also what `peha mfb-emulator` simulates.
sim::RightArmPlantParams postures_plant_params(const ArmScenario& scenario);
/// When the operator lets go of each posture, s (E3's script), and the run's length (the whole
/// script, or up to scenario.postures_stop_s when that is set).
std::vector<double> postures_release_times_s(const ArmScenario& scenario);
double postures_duration_s(const ArmScenario& scenario);

/// E3 on any backend. `sim` (optional) is the in-process arm when `backend` is it (truth figures);
/// without it the drift comes from the joint encoders, forces and tensions from the load cells, and
/// the operator is where the script puts them. A cycle whose read() fails holds the last command.
PosturesResult run_postures_on(const ArmScenario& scenario, io::Backend& backend, const sim::RightArmBackend* sim, runtime::RowSink* log,
                               const runtime::CycleHooks& hooks = {});

}  // namespace peha::experiments
