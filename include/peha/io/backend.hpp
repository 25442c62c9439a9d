#pragma once
/// \file
/// The one interface between controllers and an exoskeleton: sensor state in, command out, and the
/// hardware's lifecycle (after ros2_control's hardware components).
///
/// Implementations: the in-process simulators (`sim::OneDofRigBackend`, `sim::ArmBackend`) and
/// the multifunction board over UDP (`mfb::UdpBackend`). Controllers never see anything else of the
/// plant. Every command passes the limits layer on its way in: experiments write through
/// `safety::LimitedBackend`, which wraps the backend, so no command reaches `write` unlimited.
///
/// Lifecycle, driven by the run (runtime::Supervisor keeps the named states):
///   configure()  set-up: open the link (a board's session handshake). May throw.
///   activate()   outputs follow the commands from now on (a board's enable edge).
///   deactivate() outputs to their safe state: motor off, valves vent slowly. Commands are ignored.
///   estop()      the software e-stop: safe outputs now, latched until deactivate() + activate().
///   status()     what the loop's supervisor needs to detect a fault.

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace peha::io {

/// Fixed capacity so that states and commands are plain values (no allocation in the loop).
inline constexpr int kMaxJoints = 16;
/// "Not measured" (an optional sensor a backend lacks, a figure a run did not produce).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// What the sensors of one joint report, already converted to SI by the backend's channel map.
struct JointSensors {
  double angle_rad = 0;              ///< joint encoder
  double agonist_loadcell_N = 0;        ///< load cell at the agonist's tip (muscle side of the cable)
  double antagonist_loadcell_N = 0;     ///< load cell at the antagonist's tip
  double agonist_pressure_Pa = 0;    ///< valve pressure sensor, gauge
  double antagonist_pressure_Pa = 0; ///< valve pressure sensor, gauge
  /// Optional sensors: NaN when the backend does not measure them (e.g. a channel map without them).
  /// The supply line's pressure at this joint's valves, gauge (a sensor on the valve manifold).
  double supply_pressure_Pa = std::numeric_limits<double>::quiet_NaN();
  /// The motor driver's current monitor as torque at the joint (current x torque constant x gear), Nm.
  double motor_torque_Nm = std::numeric_limits<double>::quiet_NaN();
  /// A second encoder of the same joint, on the joint's own axis (angle_rad counts the motor shaft
  /// through the gear), rad: the supervisor's cross-check of the angle (a frozen or slipping encoder).
  double redundant_angle_rad = std::numeric_limits<double>::quiet_NaN();
  /// What the board's own limits do to this joint now, whatever was commanded (a board's state
  /// packet: docs/mfb-protocol.md): kBoardVentedAgonist, kBoardVentedAntagonist, kBoardMotorOff;
  /// always 0 from a backend without limits of its own (the in-process simulators).
  std::uint8_t board_limits = 0;
};

/// JointSensors::board_limits bits.
inline constexpr std::uint8_t kBoardVentedAgonist = 0x01;     ///< the agonist vented by a board limit
inline constexpr std::uint8_t kBoardVentedAntagonist = 0x02;  ///< the antagonist vented by a board limit
inline constexpr std::uint8_t kBoardMotorOff = 0x04;          ///< the motor cut by the board's range

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
  /// The zero the controller subtracts from each load cell (agonist, antagonist): its start-up tare or
  /// configured zero. Told to the supervisor, which judges a wire's tension by it; never sent to a board.
  std::array<double, 2> loadcell_zero_N{};
};

struct Command {
  int joint_count = 0;
  std::array<JointCommand, kMaxJoints> joints{};
};

/// `to = from` for the joints in use only (the capacity is kMaxJoints, usually far more than a body
/// drives): what per-cycle code copies, so a larger capacity costs nothing per cycle. Joints beyond
/// `from.joint_count` keep what they held (nobody reads them: a run's joint count does not change).
inline void copy_used(Command& to, const Command& from) noexcept {
  const int n = from.joint_count < 0 ? 0 : (from.joint_count > kMaxJoints ? kMaxJoints : from.joint_count);
  to.joint_count = from.joint_count;
  for (int j = 0; j < n; ++j) to.joints[static_cast<std::size_t>(j)] = from.joints[static_cast<std::size_t>(j)];
}
// copy_used copies every field but the unused joints: a new field must be added there too.
static_assert(sizeof(Command) == sizeof(double) + kMaxJoints * sizeof(JointCommand), "Command gained a field: copy it in copy_used");
static_assert(sizeof(SensorState) == 3 * sizeof(double) + kMaxJoints * sizeof(JointSensors),
              "SensorState gained a field: copy it in copy_used");
inline void copy_used(SensorState& to, const SensorState& from) noexcept {
  const int n = from.joint_count < 0 ? 0 : (from.joint_count > kMaxJoints ? kMaxJoints : from.joint_count);
  to.time_s = from.time_s;
  to.sequence = from.sequence;
  to.joint_count = from.joint_count;
  for (int j = 0; j < n; ++j) to.joints[static_cast<std::size_t>(j)] = from.joints[static_cast<std::size_t>(j)];
}

/// Static description of what a backend drives.
struct BackendInfo {
  std::string name;                      ///< e.g. "sim:one_dof_rig"
  std::vector<std::string> joint_names;  ///< one per joint
  double period_s = 1e-3;                ///< control period the backend runs at
};

/// What a backend tells its supervisor each cycle. noexcept to read, no allocation.
struct BackendStatus {
  bool active = false;            ///< outputs follow the commands (activated, not e-stopped, not tripped)
  bool estop = false;             ///< an e-stop holds the outputs safe (input line, board status or estop())
  bool watchdog_tripped = false;  ///< the backend's own watchdog put the outputs in their safe state
  bool ready_to_arm = true;       ///< activate() now would arm the outputs (a board has seen a disabled command)
  bool rebooted = false;          ///< the board restarted during the run (a new boot id): its outputs lost their
                                  ///< arming and state; latched until deactivate()
  std::int64_t last_sample_ns = 0;///< monotonic ns when the newest sample arrived (0: the backend has its own
                                  ///< clock and is never silent, e.g. a simulator)
  double last_rtt_s = 0;          ///< round trip of the newest sample's command, s (0: not measured)
  std::uint64_t rtt_samples = 0;  ///< how many round trips were measured (a new one when it grows)
  /// A backend made of parts (mfb::BoardsBackend: several boards): the part the fault above (or the
  /// oldest sample) comes from, e.g. "board 'left'", for the supervisor's fault reason; nullptr:
  /// the whole backend. Points to a string the backend owns for its lifetime.
  const char* part = nullptr;
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual const BackendInfo& info() const = 0;
  /// Set-up: opens the link (the board's session). Throws std::runtime_error if it cannot.
  virtual void configure() {}
  /// Outputs follow the commands from now on.
  virtual void activate() noexcept = 0;
  /// Outputs to their safe state (motor off, valves vent slowly); commands are ignored until activate().
  virtual void deactivate() noexcept = 0;
  /// Safe outputs now; latched until deactivate() and activate().
  virtual void estop() noexcept = 0;
  virtual BackendStatus status() const noexcept = 0;
  /// Latest sensor sample. Returns false if no valid sample is available (the caller holds).
  virtual bool read(SensorState& state) noexcept = 0;
  /// Sends a command (already limited). For the simulator this also advances time by one period.
  virtual bool write(const Command& command) noexcept = 0;
};

}  // namespace peha::io
