#pragma once
/// \file
/// The simulated right-arm exoskeleton (docs/models.md): MuJoCo's rigid bodies of the exoskeleton,
/// the strapped-on user/mannequin arm and the payload (generated from a models::ArmModel), one
/// sim::PehaJointPlant per actuated joint (R_SFE and R_EFE with motors, R_WFE with its DMSP-10 pair
/// only), joint encoders, and the operator's hands: a joint-space impedance that moves the arm to a
/// posture and lets go. Controllers see it only through io::Backend (io joint i = actuated joint i).

#include "peha/io/backend.hpp"
#include "peha/models/arm.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "peha/sim/mujoco_model.hpp"
#include "peha/sim/output_gate.hpp"
#include "peha/sim/peha_joint_plant.hpp"
#include "peha/sim/plant_faults.hpp"

#include <Eigen/Dense>

#include <random>
#include <string>
#include <vector>

namespace peha::sim {

/// One move of the operator: grip the arm where it is, carry the actuated joints to `target_rad`
/// (NaN = leave that joint free) on a minimum-jerk path over `move_s`, hold until `duration_s`, let go.
struct OperatorMove {
  std::string name;
  double start_s = 0;
  double duration_s = 1;
  double move_s = 1;
  std::vector<double> target_rad;  ///< one per actuated joint
};

/// The operator's hands as a joint-space impedance, saturated per joint.
struct OperatorParams {
  double stiffness_Nm_per_rad = 80;
  double damping_Nms_per_rad = 8;
  double max_torque_Nm = 25;
  /// The operator follows the start-up procedure: lets go only when the run is ready (keep_hands).
  /// false: a careless operator who follows the clock whatever peha shows.
  bool waits_until_ready = true;
  std::vector<OperatorMove> moves;
};

struct ArmPlantParams {
  models::ArmModel model;                 ///< the plant's true rigid bodies (payload included)
  /// Plant-only: mass added to the model's body "payload" (held in the hand) that the controller
  /// is not told, kg; may be < 0 for a lighter payload than believed, but the payload's total mass
  /// must stay >= 0. Default 0.
  double unknown_hand_payload_kg = 0.0;
  ArmMjcfOptions mjcf;                    ///< ranges, passive damping, the R_WR clamp
  double timestep_s = 0.0005;             ///< MuJoCo step; divides the control period
  double control_period_s = 0.001;
  std::vector<std::string> actuated;      ///< names of the actuated joints, in io order
  std::vector<PehaJointPlantParams> actuators;  ///< one per actuated joint
  std::vector<double> initial_q_rad;      ///< one per model joint
  /// Physics run before t = 0 with the board's outputs safe (vented, motors off) and no hands on the
  /// arm, s: a real arm at power-on hangs at rest, so the run starts from rest and its start-up
  /// (vent, tare, refill) is judged on what the start-up does, not on a made-up initial state.
  double settle_s = 1.5;
  double pressure_noise_Pa = 1000;
  double pressure_range_Pa = 1.0e6;
  double encoder_counts_per_rev = 70000;
  /// The redundant encoder on each actuated joint's axis, counts per revolution (0: none).
  double joint_encoder_counts_per_rev = 0;
  OperatorParams operator_hands;
  std::uint64_t seed = 1;
  /// Plant-only: faults injected at their time (sim/plant_faults.hpp; PlantFault::joint indexes
  /// `actuated`); never told to the controller. Supply faults act on every actuated joint (the arm
  /// has one supply); controller_nan is the experiment's to apply (E3's step), not the plant's.
  std::vector<PlantFault> faults;
};

/// The plant's truth for logs and figures.
struct ArmTruth {
  double time_s = 0;
  std::vector<double> q_rad, qd_radps;           ///< every model joint
  std::vector<PehaJointTruth> actuators;         ///< per actuated joint
  std::vector<double> operator_torque_Nm;        ///< per actuated joint
  std::vector<double> actuated_q_rad;            ///< per actuated joint: its angle (q_rad is per model joint)
  /// Per actuated joint, from MuJoCo at the latest physics step:
  std::vector<double> actuator_torque_Nm;        ///< cables (muscle-side tensions x pulley) + motor, as applied
  std::vector<double> constraint_torque_Nm;      ///< what the friction, joint-limit and lock constraints apply (qfrc_constraint)
  std::vector<double> bias_torque_Nm;            ///< gravity + Coriolis the joint carries (qfrc_bias; at rest: gravity)
  bool operator_active = false;
};

class ArmBackend final : public io::Backend {
 public:
  explicit ArmBackend(const ArmPlantParams& params);
  const io::BackendInfo& info() const override { return info_; }
  bool read(io::SensorState& state) noexcept override;
  void activate() noexcept override { gate_.activate(); }
  void deactivate() noexcept override { gate_.deactivate(); }
  void estop() noexcept override { gate_.estop(); }
  io::BackendStatus status() const noexcept override { return gate_.status(); }
  /// Writes step the plant by one control period with the command - or, unless activated, with the
  /// safe outputs (OutputGate: motor off, valves vented over vent_s; the dump valves vent past a stuck
  /// valve). The faults due by then take effect first.
  bool write(const io::Command& command) noexcept override;
  /// The truth at the latest sample (after the latest write()).
  const ArmTruth& truth() const { return truth_; }
  /// The operator's side of the start-up procedure (docs/safety.md "Start-up"): the hands that hold
  /// the arm from t = 0 (the first move, if it starts at 0) let go only once the run is ready (every
  /// joint carried, no fault). While `keep` they stay on, holding the move's posture past its end, and
  /// the rest of the script waits; once not, the script goes on from where its clock is.
  void keep_hands(bool keep) noexcept {
    if (!keep || !params_.operator_hands.waits_until_ready) kept_move_ = -1;
    else if (kept_move_ < 0 && active_move_ == 0 && params_.operator_hands.moves.front().start_s <= 0.0) kept_move_ = 0;
  }
  /// The truth at the instant of the sample the latest read() returned (see OneDofRigBackend).
  const ArmTruth& sampled_truth() const { return sampled_truth_; }

 private:
  void substep(const io::Command& command) noexcept;
  void settle();
  void sample() noexcept;
  void apply_faults(double t_s) noexcept;

  ArmPlantParams params_;
  io::BackendInfo info_;
  ModelPtr model_;
  DataPtr data_;
  std::vector<int> dof_;                 ///< MuJoCo dof of each actuated joint
  std::vector<PehaJointPlant> joints_;
  std::vector<double> base_frictionloss_, base_damping_;
  std::vector<double> move_start_;       ///< angle where the current move began, per actuated joint
  int active_move_ = -1;
  int kept_move_ = -1;  ///< the start-up hold the operator keeps on (keep_hands)
  int substeps_ = 1;
  bool settling_ = false;  ///< before t = 0: no operator's hands
  std::mt19937_64 rng_;
  io::SensorState state_;
  ArmTruth truth_, sampled_truth_;
  OutputGate gate_;
  std::vector<char> fault_applied_;         ///< per params_.faults: already in effect
  std::vector<double> encoder_offset_rad_;  ///< per actuated joint: an injected encoder jump
  std::vector<char> encoder_frozen_;        ///< per actuated joint: the encoder repeats its reading
};

}  // namespace peha::sim
