#pragma once
/// \file
/// Faults the simulated plant can inject (docs/safety.md): each one a kind, the instant it starts
/// (it then stays), the joint and muscle it hits and, for some, a value. Plant-only: the controller
/// and the supervisor never read this; they see the fault only through the sensors, as on hardware.
///
/// Given in a scenario's `faults:` list (`- {kind: loadcell_stuck, time_s: 3, joint: joint, muscle:
/// agonist}`) or on the command line as `--fault KIND@T[:TARGET[=VALUE]]`, TARGET being
/// `JOINT.MUSCLE`, `MUSCLE` (the first joint), or `JOINT` for joint-wide kinds.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace peha::sim {

enum class FaultKind {
  kLoadcellStuck,         ///< the load cell repeats its last reading
  kLoadcellBias,          ///< the load cell reads `value` N more (default 400 N)
  kLoadcellDisconnected,  ///< the load cell's channel reads AD code 0
  kLoadcellSaturated,     ///< the load cell's channel reads full scale
  kEncoderJump,           ///< the encoder's count jumps by `value` deg (default 10) once, and stays off
  kEncoderFrozen,         ///< the encoder repeats its last reading
  kPressureSensorFail,    ///< the pressure sensor's channel reads AD code 0
  kSupplyZero,            ///< the compressor's supply falls to 0 (a check valve keeps the muscles' air)
  kSupplyHalf,            ///< the supply falls to half
  kValveStuckOpen,        ///< the valve fills to supply whatever its command (a dump valve still vents)
  kValveStuckClosed,      ///< the valve holds the chamber's air whatever its command
  kWireBreak,             ///< the muscle's wire breaks: no tension
  kWireSlip,              ///< the wire slips in its clamp by `value` mm (default 5) once
  kMotorFault,            ///< the motor's driver gives no torque
  kControllerNan,         ///< the controller's command on the joint becomes NaN (applied by the loop's test driver)
  kEstop,                 ///< the operator presses the e-stop
  kLoadcellDrift,         ///< the load cell's zero drifts by `value` N/s (default 10) from the fault on
  /// The board's state packets are lost for `value` s (default 2.5): no sample reaches the host,
  /// while the board still hears it and its outputs follow the last command (an outage, not a fault
  /// of the plant: OutputGate); then the samples come back.
  kStateLoss,
  /// The board is off for `value` s (default 2.5) and boots again: no sample, its outputs in their
  /// safe state (vented, motor off) from the fault on; back, it reports the restart and stays
  /// disarmed until the host re-arms it (OutputGate).
  kBoardReboot,
};

inline constexpr int kFaultKindCount = 19;

/// "loadcell_stuck", ... (the names the YAML and --fault take).
const char* fault_kind_name(FaultKind kind) noexcept;
/// All kinds in enum order.
const std::array<FaultKind, kFaultKindCount>& all_fault_kinds() noexcept;
/// The kind hits one muscle (else the joint or the whole plant).
bool fault_targets_muscle(FaultKind kind) noexcept;
/// The kind is an outage of the link or the board (state_loss, board_reboot; `value` is its length
/// in s), which the plant's OutputGate plays, not its joints.
bool is_outage(FaultKind kind) noexcept;
/// The kind takes a value, and its default.
bool fault_takes_value(FaultKind kind) noexcept;
double fault_default_value(FaultKind kind) noexcept;
/// "kind1|kind2|..." for --help and errors.
std::string fault_kind_list();

struct PlantFault {
  FaultKind kind = FaultKind::kLoadcellStuck;
  double time_s = 0;
  int joint = 0;   ///< index into the plant's joint names
  int muscle = 0;  ///< 0 agonist, 1 antagonist (muscle kinds only)
  double value = 0;
};

/// Parses "KIND@T[:TARGET[=VALUE]]" against the plant's joint names. Throws std::invalid_argument
/// naming what was expected and what was found.
PlantFault parse_fault_spec(std::string_view spec, const std::vector<std::string>& joint_names, double duration_s);

/// Reads the optional `faults:` list of a scenario root (empty when absent). Does not finish `root`.
std::vector<PlantFault> read_plant_faults(config::Map& root, const std::vector<std::string>& joint_names, double duration_s);

struct JointFaultState;
/// Sets the joint-level effect of `f` (load cells, pressure sensors, valves, wires, supply, motor) in
/// `joint`; kinds the joint does not model (encoder, e-stop, controller) are left to the caller.
void apply_joint_fault(const PlantFault& f, JointFaultState& joint) noexcept;
/// The faults that grow with time (a drifting load cell) at time `t_s`; every step.
void advance_joint_faults(double t_s, JointFaultState& joint) noexcept;

/// The controller_nan faults of a run: the test driver's part of the plant's fault injection. From
/// each one's time on, the controller's agonist command on its joint is NaN, before the supervisor.
class ControllerNanInjection {
 public:
  explicit ControllerNanInjection(const std::vector<PlantFault>& faults) noexcept;
  /// Corrupts `command` (just computed by the controller at `t_s`) where a controller_nan is due.
  void apply(double t_s, io::Command& command) const noexcept;

 private:
  std::array<double, io::kMaxJoints> from_s_{};
};

/// "loadcell_stuck@3s joint.agonist" for logs and tables.
std::string describe(const PlantFault& f, const std::vector<std::string>& joint_names);

}  // namespace peha::sim
