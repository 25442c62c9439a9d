#pragma once
/// \file
/// The simulated one-DOF PEHA test rig (SPEC §1, §4, experiment E1): a MuJoCo hinge with link and
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
#include "peha/sim/plant_muscle.hpp"
#include "peha/sim/valve.hpp"

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace peha::sim {

/// The Bowden cable as the plant has it (not the controller's model).
struct CablePlantParams {
  double kinetic_friction = 0.05;        ///< mu while sliding
  double static_friction = 0.08;         ///< mu at rest (stiction), >= kinetic
  double stribeck_velocity_mps = 0.002;  ///< wire speed over which mu falls from static to kinetic
  double wrap_angle_rad = 3.14;          ///< psi, total bend of the housing
  double wire_stiffness_N_per_m = 1.5e5; ///< inner wire + housing compression, N/m
  double initial_slack_m = 0.002;        ///< slack of the wire at the start
  double creep_m_per_N_s = 0.0;          ///< slow lengthening of the wire under tension
  double max_creep_m = 0.003;            ///< creep saturates here
};

struct MusclePlantParams {
  std::filesystem::path law_file;     ///< YAML of the fitted static law
  PlantMuscleParams law;
  double rest_length_m = 0.4;         ///< L0 of the muscle
  double contraction_at_zero_angle = 0.1;  ///< rigid-wire contraction at joint angle 0
  double initial_pressure_Pa = 0.0;   ///< chamber pressure at t = 0
  ValveParams valve;
  CablePlantParams cable;
  double loadcell_noise_N = 1.0;      ///< standard deviation of the load-cell noise
  double loadcell_range_N = 5000.0;   ///< full scale of the load cell's 16-bit AD channel
};

struct MotorPlantParams {
  double gear_ratio = 35.0;                     ///< 14:1 planetary x 5:2 bevel
  double rotor_inertia_kgm2 = 3.33e-6;          ///< reflected to the joint as gear^2 x this
  double coulomb_friction_Nm = 0.08;            ///< at the joint
  double viscous_friction_Nms_per_rad = 0.02;   ///< at the joint
  double max_torque_Nm = 2.5;                   ///< at the joint; the driver saturates here
};

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
  double pulley_radius_m = 0.05;
  double payload_kg = 2.5;
  double initial_angle_rad = 0.0;
  MusclePlantParams agonist;
  MusclePlantParams antagonist;
  MotorPlantParams motor;
  double pressure_noise_Pa = 1000;     ///< standard deviation of the pressure sensors' noise
  double pressure_range_Pa = 1.0e6;    ///< full scale of the pressure sensors' AD channels
  double encoder_counts_per_rev = 70000;  ///< joint counts per revolution (motor encoder x gear)
  FingerParams finger;
  std::uint64_t seed = 1;
};

/// Reads the `plant:` mapping of a scenario (the finger and payload come from the scenario).
OneDofRigParams read_one_dof_rig(config::Map& plant, double control_period_s, double supply_pressure_Pa);

/// What really happens in the plant at the current sample (for logs, never for the controller).
struct OneDofRigTruth {
  double time_s = 0;
  double angle_rad = 0;
  double velocity_radps = 0;
  double finger_force_N = 0;            ///< along the link's upward normal at the finger
  bool finger_active = false;
  double muscle_force_N[2] = {0, 0};    ///< muscle-side wire tension = muscle force (agonist, antagonist)
  double pulley_tension_min_N[2] = {0, 0};  ///< lowest tension anywhere along each wire
  double pressure_Pa[2] = {0, 0};
  double muscle_contraction[2] = {0, 0};
  double motor_torque_Nm = 0;
  double cable_friction_Nm = 0;         ///< friction bound the cables put on the joint now
  double constraint_torque_Nm = 0;      ///< what MuJoCo's friction and joint-limit constraints applied
  double creep_m[2] = {0, 0};
};

class OneDofRigBackend final : public io::Backend {
 public:
  explicit OneDofRigBackend(const OneDofRigParams& params);
  const io::BackendInfo& info() const override { return info_; }
  bool read(io::SensorState& state) noexcept override;
  bool write(const io::Command& command) noexcept override;
  const OneDofRigTruth& truth() const { return truth_; }
  const OneDofRigParams& params() const { return params_; }

 private:
  struct Muscle {
    const MusclePlantParams* p;
    int side;
    Valve valve;
    double tension_N = 0;
    double contraction = 0;
    double creep_m = 0;
  };
  void substep(const io::JointCommand& cmd) noexcept;
  void solve_muscle(Muscle& m, double angle_rad, double dt_s) noexcept;
  double finger_force(double t, double angle, double omega) noexcept;
  void sample() noexcept;
  double quantize(double value, double range) const noexcept;

  OneDofRigParams params_;
  io::BackendInfo info_;
  ModelPtr model_;
  DataPtr data_;
  int dof_ = 0;
  int link_body_ = 0;
  double base_damping_ = 0;
  double base_frictionloss_ = 0;
  int substeps_ = 1;
  Muscle muscles_[2];
  std::mt19937_64 rng_;
  std::normal_distribution<double> unit_normal_{0.0, 1.0};
  std::vector<double> push_start_angle_;  ///< angle where each push began (NaN until it starts)
  io::SensorState state_;
  OneDofRigTruth truth_;
};

}  // namespace peha::sim
