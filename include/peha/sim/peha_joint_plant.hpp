#pragma once
/// \file
/// One simulated PEHA joint, as the plant has it (docs/simulator.md): an agonist and an antagonist muscle
/// (fitted static law with hysteresis), each behind its servo valve and its Bowden cable (elastic
/// inner wire with slack and creep, capstan friction with stiction), plus an optional geared motor.
/// It turns a command and the joint's angle/velocity into a joint torque and a friction bound for
/// the rigid-body simulation, and produces the joint's sensor readings. Used by every simulated
/// exoskeleton (the one-DOF rig, the right arm); the rigid bodies are MuJoCo's.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/sim/plant_muscle.hpp"
#include "peha/sim/valve.hpp"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <random>

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
  /// Plant-only load-cell error (the controller is never told): the reading is
  /// `loadcell_gain * T + loadcell_offset_N + noise`, then 16-bit quantised. Neutral: 0 N and 1.
  double loadcell_offset_N = 0.0;
  double loadcell_gain = 1.0;
};

struct MotorPlantParams {
  double gear_ratio = 35.0;                     ///< 14:1 planetary x 5:2 bevel
  double rotor_inertia_kgm2 = 3.33e-6;          ///< reflected to the joint as gear^2 x this
  double coulomb_friction_Nm = 0.08;            ///< at the joint
  double viscous_friction_Nms_per_rad = 0.02;   ///< at the joint
  double max_torque_Nm = 2.5;                   ///< at the joint; the driver saturates here
};

struct PehaJointPlantParams {
  double pulley_radius_m = 0.05;
  /// Plant-only: the valves of this joint cannot exceed this pressure (a weaker compressor), Pa,
  /// whatever the supply the controller and limits believe in. +inf (default): no cap.
  double supply_cap_Pa = std::numeric_limits<double>::infinity();
  MusclePlantParams agonist;
  MusclePlantParams antagonist;
  bool has_motor = true;
  MotorPlantParams motor;  ///< ignored when has_motor is false
};

/// Reads a joint's keys from `map` (pulley_radius_m, optional supply_cap_MPa, agonist{...},
/// antagonist{...}, and motor{...} when `has_motor`); does not finish `map` (it may hold other keys
/// of the caller's).
PehaJointPlantParams read_peha_joint_plant(config::Map& map, double supply_pressure_Pa, bool has_motor);

/// What really happens in the joint's actuators now (for logs, never for the controller).
struct PehaJointTruth {
  double muscle_force_N[2] = {0, 0};        ///< muscle-side wire tension = muscle force (agonist, antagonist)
  double pulley_tension_min_N[2] = {0, 0};  ///< lowest tension anywhere along each wire
  /// Tension where each wire leaves its housing at the joint's pulley: the capstan's stick band
  /// T e^-x <= T_joint <= T e^x (x = mu psi) with memory - while the wire does not slip the joint end
  /// keeps its tension, and when the muscle's tension leaves the band the wire slips and the joint end
  /// follows the band's edge. What a torque sensor behind the pulley would see of the muscles.
  double joint_side_tension_N[2] = {0, 0};
  double pressure_Pa[2] = {0, 0};
  double muscle_contraction[2] = {0, 0};
  double creep_m[2] = {0, 0};
  double motor_torque_Nm = 0;
  double cable_friction_Nm = 0;             ///< friction bound the cables put on the joint now
  /// r (T_joint agonist - T_joint antagonist) + motor: the torque at the joint after the cables.
  double joint_torque_after_cable_Nm = 0;
};

/// Faults injected into one joint (plant-only, sim/plant_faults.hpp; the controller never sees this).
/// Arrays: index 0 agonist, 1 antagonist.
struct JointFaultState {
  bool loadcell_stuck[2] = {false, false};
  bool loadcell_disconnected[2] = {false, false};  ///< reads AD code 0
  bool loadcell_saturated[2] = {false, false};     ///< reads full scale
  double loadcell_bias_N[2] = {0, 0};
  double loadcell_drift_N_per_s[2] = {0, 0};       ///< a zero drifting from drift_since_s on
  double loadcell_drift_since_s[2] = {0, 0};
  double loadcell_drift_N[2] = {0, 0};             ///< how far it has drifted (advance_joint_faults)
  bool pressure_sensor_failed[2] = {false, false}; ///< reads AD code 0
  bool valve_stuck_open[2] = {false, false};
  bool valve_stuck_closed[2] = {false, false};
  bool wire_broken[2] = {false, false};
  double wire_slip_m[2] = {0, 0};                  ///< extra slack from a wire slipping in its clamp
  double supply_scale = 1.0;                       ///< supply line pressure / nominal
  bool motor_failed = false;
  /// The outputs are in their safe state: the board's dump valve vents the chambers past a stuck valve.
  bool dump = false;
};

class PehaJointPlant {
 public:
  PehaJointPlant(const PehaJointPlantParams& params, double timestep_s, double initial_angle_rad);

  /// Set-up constants for the joint's MuJoCo dof (the motor's share): reflected rotor inertia
  /// (kg m^2), viscous friction (Nm s/rad), Coulomb friction (Nm).
  double armature_kgm2() const;
  double viscous_friction_Nms_per_rad() const;
  double coulomb_friction_Nm() const;

  struct Forces {
    double torque_Nm = 0;         ///< cables + motor, to apply to the joint
    double friction_bound_Nm = 0; ///< the cables' capstan friction bound (stick-slip via MuJoCo)
  };
  /// One physics step of `timestep_s` at the joint's current angle and velocity. noexcept.
  Forces step(const io::JointCommand& command, double angle_rad, double velocity_radps) noexcept;

  /// The load cells and pressure sensors (noise drawn from `rng`, 16-bit quantised) into `out`;
  /// the angle is the caller's (encoder). Draw order: agonist force, antagonist force, agonist
  /// pressure, antagonist pressure. Also the supply pressure at the valves (16-bit over
  /// pressure_range_Pa) and, with a motor, the driver's current monitor as torque at the joint
  /// (16-bit over +-1.2 x the rating; NaN without a motor); neither draws noise.
  void sense(double pressure_noise_Pa, double pressure_range_Pa, std::mt19937_64& rng, io::JointSensors& out) noexcept;

  const PehaJointTruth& truth() const { return truth_; }
  /// The injected faults of this joint (the rig applies them at their time).
  JointFaultState& faults() noexcept { return faults_; }
  const PehaJointPlantParams& params() const { return params_; }

 private:
  // No pointer into params_: a PehaJointPlant is moved (e.g. kept in a std::vector by the arm).
  struct Muscle {
    int side;
    Valve valve;
    double tension_N = 0;
    double contraction = 0;
    double creep_m = 0;
  };
  void solve_muscle(Muscle& m, double angle_rad) noexcept;
  const MusclePlantParams& muscle_params(const Muscle& m) const noexcept {
    return m.side > 0 ? params_.agonist : params_.antagonist;
  }
  /// The supply at a muscle's valve: its valve's supply, capped by the plant, scaled by a supply fault
  /// (what the valve fills from, and what the manifold's supply sensor reads).
  double supply_Pa(const MusclePlantParams& m) const noexcept {
    return faults_.supply_scale * std::min(m.valve.supply_pressure_Pa, params_.supply_cap_Pa);
  }

  PehaJointPlantParams params_;
  double timestep_s_;
  /// The two cables' friction parameters are equal: the capstan terms of one serve both (step()).
  bool cables_mirrored_ = false;
  Muscle muscles_[2];
  std::normal_distribution<double> unit_normal_{0.0, 1.0};
  PehaJointTruth truth_;
  JointFaultState faults_;
  double last_loadcell_N_[2] = {0, 0};
};

/// 16-bit AD quantisation of `value` over [0, range].
double quantize_16bit(double value, double range) noexcept;

/// 16-bit offset-binary quantisation of `value` over [-half_range, half_range): code 32768 is exactly
/// 0, one code is 2 half_range / 65536 (as the board's motor channels, docs/channel-maps.md).
double quantize_16bit_offset_binary(double value, double half_range) noexcept;

/// What an incremental encoder with `counts_per_rev` reports for `angle_rad` (floored to a count).
double encoder_angle_rad(double angle_rad, double counts_per_rev) noexcept;
/// The redundant joint-side encoder's reading (io::JointSensors::redundant_angle_rad): NaN without
/// one (counts_per_rev 0). The injected encoder faults hit the primary encoder only.
double redundant_encoder_angle_rad(double angle_rad, double counts_per_rev) noexcept;

/// Minimum-jerk blend 10 s^3 - 15 s^4 + 6 s^5 of s in [0, 1] (clamped): the path a person's hand takes.
double minimum_jerk(double s) noexcept;

/// Reads `timestep_s` (MuJoCo's step) from a plant mapping; it must divide `control_period_s`.
double read_timestep_s(config::Map& plant, double control_period_s);

}  // namespace peha::sim
