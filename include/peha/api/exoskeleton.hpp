#pragma once
/// \file
/// Your own 1 kHz controller on a peha exoskeleton, in the spirit of libfranka's
/// `robot.control(callback)`: open an arm scenario on any backend (the simulated arm, the board over
/// UDP), get a callback every control period with what the sensors measured, return the torque each
/// joint should get. peha does the rest around it, exactly as for its own experiments: the
/// macro-mini allocation of each torque to the muscle pair and the motor (wires never slack), the
/// start-up tare, the limits stage and the plausibility monitor on every command, the lifecycle
/// supervisor (watchdogs, faults, the operator's recovery) on the board, the per-cycle log and a
/// verdict (the safety envelope, faults). docs/user-controller.md; example: examples/pd_gravity.cpp.
///
///   peha::api::Exoskeleton exo("configs/right_arm.yaml");          // or ("...", "udp://10.0.0.2:50000")
///   auto result = exo.control([&](const peha::api::ArmState& s, double) {
///     peha::api::JointTorques tau;
///     for (int j = 0; j < s.joint_count; ++j) tau.tau_Nm[j] = s.joints[j].gravity_torque_Nm + 20.0 * (q0[j] - s.joints[j].angle_rad);
///     return tau;
///   }, 5.0);
///
/// The callback runs on the control thread: it must not block, and should not allocate (peha's own
/// step allocates nothing; a callback that does costs its own time on the 1 ms budget). Joints the
/// scenario holds at constant pressure (a passive wrist) keep their hold whatever is returned.

#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/io/backend.hpp"
#include "peha/safety/verdict.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace peha::api {

/// What one joint's sensors measured this period, and the controller's model there.
struct JointState {
  double angle_rad = 0;            ///< joint encoder
  double velocity_radps = 0;       ///< filtered encoder derivative (the scenario's velocity_cutoff_Hz)
  double gravity_torque_Nm = 0;    ///< the controller's gravity model (J^T G) at this posture
  double agonist_loadcell_N = 0;   ///< load cells at the muscles' ends of the wires (less their start-up tare)
  double antagonist_loadcell_N = 0;
  double agonist_pressure_Pa = 0;  ///< valve pressure sensors, gauge
  double antagonist_pressure_Pa = 0;
};

struct ArmState {
  double time_s = 0;                                ///< the backend's time stamp
  /// peha's start-up is running (the load cells' tare vents the muscles, then the wires refill):
  /// the arm hangs in the hand that holds it, and a position loop should wait for it to end.
  bool starting = false;
  int joint_count = 0;                              ///< the scenario's io joints (Exoskeleton::joint_names)
  std::array<JointState, io::kMaxJoints> joints{};
};

/// What the callback returns: the torque each joint should get (gravity included: the callback
/// decides; ArmState gives the model's), and whether the run is done.
struct JointTorques {
  std::array<double, io::kMaxJoints> tau_Nm{};
  bool finished = false;  ///< end the run after this period (libfranka's MotionFinished)
};

using TorqueController = std::function<JointTorques(const ArmState& state, double period_s)>;

/// What a run gives back.
struct ControlResult {
  safety::Verdict verdict;         ///< the safety envelope (forces, tensions, pressures, motor, range) and faults
  bool passed = false;             ///< verdict.passed()
  std::uint64_t cycles = 0;        ///< control periods run
  std::uint64_t faults = 0;        ///< plausibility faults latched (in process) and lifecycle faults (on the board)
  std::string fault_reason;        ///< the first fault, "" without one
  double realtime_factor = 0;      ///< simulated time / wall time (1 on the board)
  std::filesystem::path log;       ///< the per-cycle log, when one was asked for
};

class Exoskeleton {
 public:
  /// Opens the arm scenario `scenario` (e.g. configs/right_arm.yaml, configs/upper_body.yaml) on
  /// `backend` (hardware::BackendUri: "sim:" the simulated arm, "udp://A.B.C.D:PORT[,...]" its
  /// board(s) in real time; replay: has no arm to move and is refused). Throws config::Error on a
  /// bad scenario, std::invalid_argument on a backend it cannot take.
  explicit Exoskeleton(const std::filesystem::path& scenario, const std::string& backend = "sim:");

  /// The io joints, in the order of ArmState::joints and JointTorques::tau_Nm.
  const std::vector<std::string>& joint_names() const { return joint_names_; }
  const experiments::ArmScenario& scenario() const { return scenario_; }
  /// False for a joint the scenario holds at constant pressure (its torque is not the callback's).
  bool torque_controlled(std::size_t joint) const;
  /// Real-time options on the board (default: SCHED_FIFO 80, memory locked, no pinning).
  void set_realtime(int fifo_priority, int cpu = -1, bool lock_memory = true);

  /// Runs `controller` every control period for `duration_s` (or until it returns finished): the
  /// returned torques through peha's allocation, limits and monitor to the backend. `log` (optional):
  /// the per-cycle CSV (what the sensors gave, the callback's torques, what was sent; replayable).
  /// Throws (set-up) when the backend cannot be opened or no board answers; never from the loop.
  ControlResult control(const TorqueController& controller, double duration_s, const std::filesystem::path& log = {});

 private:
  experiments::ArmScenario scenario_;
  std::string backend_;
  std::vector<std::string> joint_names_;
  int fifo_priority_ = 80, cpu_ = -1;
  bool lock_memory_ = true;
};

/// The per-cycle log's columns of a run with `scenario`: t_s, per io joint (its log prefix) the
/// sensors, the callback's torque, the gravity model, what was sent, the sensors a rig may lack
/// (supply, redundant encoder, motor monitor: every hardware::kSensorColumns, so the log replays with
/// --backend replay:); limit_flags, fault_flags.
std::vector<std::string> user_log_columns(const experiments::ArmScenario& scenario);

}  // namespace peha::api
