#pragma once
/// \file
/// The one interface between controllers and an exoskeleton: sensor state in, command out.
///
/// Implementations: the in-process simulator (`sim::OneDofRigBackend`) now; the MFB over UDP later.
/// Controllers never see anything else of the plant. Every command passes the limits layer
/// (`safety::CommandLimiter`) before it reaches `Backend::write`.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace peha::io {

/// Fixed capacity so that states and commands are plain values (no allocation in the loop).
inline constexpr int kMaxJoints = 8;

/// What the sensors of one joint report, already converted to SI by the backend's channel map.
struct JointSensors {
  double angle_rad = 0;              ///< joint encoder
  double agonist_force_N = 0;        ///< load cell at the agonist's tip (muscle side of the cable)
  double antagonist_force_N = 0;     ///< load cell at the antagonist's tip
  double agonist_pressure_Pa = 0;    ///< valve pressure sensor, gauge
  double antagonist_pressure_Pa = 0; ///< valve pressure sensor, gauge
};

struct SensorState {
  double time_s = 0;           ///< backend time stamp of the sample
  std::uint64_t sequence = 0;  ///< increases by one per sample
  int joint_count = 0;
  std::array<JointSensors, kMaxJoints> joints{};
};

struct JointCommand {
  double agonist_pressure_Pa = 0;
  double antagonist_pressure_Pa = 0;
  double motor_torque_Nm = 0;  ///< at the joint (after the gear)
};

struct Command {
  int joint_count = 0;
  std::array<JointCommand, kMaxJoints> joints{};
};

/// Static description of what a backend drives.
struct BackendInfo {
  std::string name;                      ///< e.g. "sim:one_dof_rig"
  std::vector<std::string> joint_names;  ///< one per joint
  double period_s = 1e-3;                ///< control period the backend runs at
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual const BackendInfo& info() const = 0;
  /// Latest sensor sample. Returns false if no valid sample is available (the caller holds).
  virtual bool read(SensorState& state) noexcept = 0;
  /// Sends a command (already limited). For the simulator this also advances time by one period.
  virtual bool write(const Command& command) noexcept = 0;
};

}  // namespace peha::io
