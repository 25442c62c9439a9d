#pragma once
/// \file
/// The simulated one-DOF PEHA test rig (docs/simulator.md, experiment E1): a MuJoCo hinge with link and
/// payload; an agonist DMSP-40 and an antagonist DMSP-10 whose static laws are fitted to the real
/// Festo maps (`plant_muscle.hpp`) with hysteresis; servo valves; Bowden cables with capstan friction,
/// stiction, an elastic inner wire, initial slack and creep; a 35:1 geared motor; noisy, quantised
/// sensors; and an operator's finger at the link tip.
///
/// This is the truth the controller never sees: it talks to it only through `io::Backend`. The
/// scenario runner may read `truth()` for logs and figures. Deterministic for a given seed; simulated
/// time does not depend on wall time.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/sim/mujoco_model.hpp"
#include "peha/sim/output_gate.hpp"
#include "peha/sim/peha_joint_plant.hpp"
#include "peha/sim/plant_faults.hpp"

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace peha::sim {

/// One push of the operator's finger: from the angle where the push starts the target angle moves
/// to `target_angle_rad` with a minimum-jerk profile over `move_s`, is held until `duration_s`, then
/// the finger lets go. A push with `hold` set is two-sided (the hand grips the link at the angle where
/// the push starts); otherwise the finger can only push toward the target.
struct FingerPush {
  std::string name;
  double start_s = 0;
  double duration_s = 1;
  double move_s = 1;
  double target_angle_rad = 0;
  bool hold = false;  ///< hold at the start angle instead of moving
  /// Pulls as well as pushes (a clamp guided to the target, as the calibration's acceptance check
  /// uses), instead of a finger that only pushes toward its target.
  bool clamp = false;
  /// A hold by something stiffer than the hand (the rig's start pin), > 0: its stiffness, damping
  /// and force limit replace the finger's for this push (0 = the finger's).
  double support_stiffness_N_per_m = 0;
  double support_damping_Ns_per_m = 0;
  double support_max_force_N = 0;
};

struct FingerParams {
  double stiffness_N_per_m = 400;  ///< of the operator's hand/finger along the tip normal
  double damping_Ns_per_m = 30;
  double max_force_N = 60;         ///< the operator cannot push harder
  double lever_m = 0.4;            ///< where on the link the finger acts
  std::vector<FingerPush> pushes;
};

struct OneDofRigParams {
  std::filesystem::path model_file;
  double timestep_s = 0.0005;          ///< MuJoCo step; must divide the control period
  double control_period_s = 0.001;
  double supply_pressure_Pa = 0.8e6;
  double payload_kg = 2.5;             ///< the case's payload at the payload lever (the controller knows it)
  /// Plant-only: mass added to the payload body that the controller is not told (may be < 0 for
  /// a lighter payload than believed; payload_kg + unknown_payload_kg must stay >= 0). Default 0.
  double unknown_payload_kg = 0.0;
  double initial_angle_rad = 0.0;
  PehaJointPlantParams joint;          ///< muscles, valves, cables, motor
  double pressure_noise_Pa = 1000;     ///< standard deviation of the pressure sensors' noise
  double pressure_range_Pa = 1.0e6;    ///< full scale of the pressure sensors' AD channels
  double encoder_counts_per_rev = 70000;  ///< joint counts per revolution (motor encoder x gear)
  /// The redundant encoder on the joint's axis, counts per revolution (0: none; io redundant_angle_rad NaN).
  double joint_encoder_counts_per_rev = 0;
  FingerParams finger;
  std::uint64_t seed = 1;
  /// Plant-only: faults injected at their time (sim/plant_faults.hpp); never told to the controller.
  std::vector<PlantFault> faults;
};

/// The rig's io joints (one, named "joint"): what its channel map names and its backend reports.
const std::vector<std::string>& one_dof_rig_joint_names();

/// Reads the `plant:` mapping of a scenario (the finger and payload come from the scenario).
OneDofRigParams read_one_dof_rig(config::Map& plant, double control_period_s, double supply_pressure_Pa);

/// What really happens in the plant at the current sample (for logs, never for the controller):
/// the joint's actuators (PehaJointTruth) and the rig's mechanics.
struct OneDofRigTruth : PehaJointTruth {
  double time_s = 0;
  double angle_rad = 0;
  double velocity_radps = 0;
  double finger_force_N = 0;            ///< along the link's upward normal at the finger
  bool finger_active = false;
  double constraint_torque_Nm = 0;      ///< what MuJoCo's friction and joint-limit constraints applied
};

class OneDofRigBackend final : public io::Backend {
 public:
  explicit OneDofRigBackend(const OneDofRigParams& params);
  const io::BackendInfo& info() const override { return info_; }
  bool read(io::SensorState& state) noexcept override;
  void activate() noexcept override { gate_.activate(); }
  void deactivate() noexcept override { gate_.deactivate(); }
  void estop() noexcept override { gate_.estop(); }
  io::BackendStatus status() const noexcept override { return gate_.status(); }
  /// Writes step the plant by one control period with the command - or, unless activated, with the
  /// safe outputs (OutputGate: motor off, valves vented over kSafeVent_s).
  bool write(const io::Command& command) noexcept override;
  /// The truth after the latest write().
  const OneDofRigTruth& truth() const { return truth_; }
  /// The truth at the instant of the sample the latest read() returned: what the figures of a
  /// cycle that read that sample describe, even after the cycle's write() stepped the plant on.
  const OneDofRigTruth& sampled_truth() const { return sampled_truth_; }
  const OneDofRigParams& params() const { return params_; }
  /// The operator's side of the start-up procedure (docs/safety.md "Start-up"): the support (a hold
  /// push with `support`) is pulled only once the run is ready (every wire taut, no fault). While
  /// `keep` (not ready) it stays in past its scheduled end, carrying the limb; pulled once not.
  void keep_support(bool keep) noexcept {
    if (!keep) kept_support_ = -1;
    else if (kept_support_ < 0) kept_support_ = active_support_;
  }

 private:
  void substep(const io::JointCommand& cmd) noexcept;
  double finger_force(double t, double angle, double omega) noexcept;
  void sample() noexcept;
  void apply_faults(double t_s) noexcept;

  OneDofRigParams params_;
  io::BackendInfo info_;
  ModelPtr model_;
  DataPtr data_;
  int dof_ = 0;
  int link_body_ = 0;
  double base_damping_ = 0;
  double base_frictionloss_ = 0;
  int substeps_ = 1;
  PehaJointPlant joint_;
  std::mt19937_64 rng_;
  std::vector<double> push_start_angle_;  ///< angle where each push began (NaN until it starts)
  int active_support_ = -1;  ///< the support push holding the link now (-1: none)
  int kept_support_ = -1;    ///< the support the operator keeps in (keep_support)
  io::SensorState state_;
  OneDofRigTruth truth_, sampled_truth_;
  OutputGate gate_;
  std::vector<char> fault_applied_;  ///< per params_.faults: already in effect
  double encoder_offset_rad_ = 0;    ///< an injected encoder jump
  bool encoder_frozen_ = false;
};

}  // namespace peha::sim
