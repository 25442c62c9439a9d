#pragma once
/// \file
/// Which board channel is which signal: the channel map between the multifunction board (MFB) and
/// the SI sensor state / command of `io::Backend`. Read from YAML (docs/channel-maps.md); nothing
/// about channels is compiled in.
///
/// The MFB has 16 AD channels and 8 DA channels (16-bit codes 0..65535), 8 quadrature encoder
/// counters (int32 counts), 8 digital output lines and 8 digital input lines (one byte each).
/// AD and DA channels are linear, `physical = offset + scale * code` in the channel's declared unit,
/// converted to SI at load. Encoders: `angle_rad = offset_rad + sign * 2 pi counts / (counts_per_rev * gear)`.
///
/// Two sides use the same map:
/// - the host (real-time PC): `decode_inputs`, `encode_outputs`, `estop_active`;
/// - the board emulator in front of the simulator: the inverses `encode_inputs`, `decode_outputs`,
///   `enable_active`, and `safe_outputs` for its watchdog.
/// Model/Data split: a `ChannelMap` is immutable after loading; every conversion is a const,
/// noexcept, allocation-free call. Loading is set-up code and throws `config::Error`.

#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/mfb/protocol.hpp"  // kAdChannels, kDaChannels, kEncoderChannels

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace peha::mfb {

inline constexpr int kDigitalLines = 8;  ///< per direction (one byte in, one byte out)
inline constexpr int kMaxCode = 65535;   ///< AD and DA codes are 0..kMaxCode

/// What the board samples, raw: AD codes, encoder counts, digital input lines (bit i = line i).
struct BoardInputs {
  std::array<std::uint16_t, kAdChannels> ad{};
  std::array<std::int32_t, kEncoderChannels> encoder{};
  std::uint8_t digital_in = 0;
};

/// What the board drives, raw: DA codes, digital output lines (bit i = line i).
struct BoardOutputs {
  std::array<std::uint16_t, kDaChannels> da{};
  std::uint8_t digital_out = 0;
};

/// One AD or DA channel and its conversion, held in SI. Unmapped signals have `channel == -1`.
struct AnalogChannel {
  int channel = -1;             ///< board channel index, -1 if the signal is not mapped
  std::string unit;             ///< unit declared in the file (the SI values below are converted)
  double scale_SI = 0;          ///< SI units per code (N, Pa, Nm or rad per code); never 0
  double offset_SI = 0;         ///< SI value at code 0
  std::uint16_t min_valid_code = 0;         ///< AD only: codes outside [min, max] are implausible
  std::uint16_t max_valid_code = kMaxCode;  ///< (e.g. a sensor at its rail); DA: always 0..kMaxCode

  bool mapped() const noexcept { return channel >= 0; }
  /// SI value of `code`.
  double to_si(std::uint16_t code) const noexcept { return offset_SI + scale_SI * code; }
  /// Nearest code to `value_SI`, clamped to 0..kMaxCode. A value outside that range, or NaN, sets
  /// `clamped` (which is never cleared); NaN gives the code nearest to 0 SI (vent / no torque).
  std::uint16_t to_code(double value_SI, bool& clamped) const noexcept;
  /// SI values at the ends of the valid codes, lower first.
  double min_si() const noexcept;
  double max_si() const noexcept;
};

/// One encoder counter: `angle_rad = offset_rad + sign * 2 pi counts / (counts_per_rev * gear)`.
struct EncoderChannel {
  int channel = -1;          ///< board counter index
  double counts_per_rev = 0; ///< counts per revolution of the encoder's shaft, as counted (after x4)
  double gear = 0;           ///< encoder-shaft revolutions per joint revolution
  int sign = 1;              ///< +1 or -1: counting direction relative to the joint's positive sense
  double offset_rad = 0;     ///< joint angle at count 0
  double rad_per_count = 0;  ///< sign * 2 pi / (counts_per_rev * gear)

  double to_rad(std::int32_t counts) const noexcept { return offset_rad + rad_per_count * counts; }
  /// Nearest count to `angle_rad`, saturated to the int32 range (NaN gives 0).
  std::int32_t to_counts(double angle_rad) const noexcept;
};

/// One digital line and the level that means "active".
struct DigitalLine {
  int line = 0;              ///< 0..7, bit index in the byte
  bool active_high = true;

  bool active(std::uint8_t byte) const noexcept { return (((byte >> line) & 1u) != 0) == active_high; }
  /// Sets the line in `byte` to its active or inactive level.
  void set(std::uint8_t& byte, bool active) const noexcept;
};

/// The board's own hard limits of one joint (`board_limits:`, docs/channel-maps.md), in SI. The
/// board core (firmware/) enforces them whatever the host sends: valve setpoints and motor torque
/// clamped to their ceilings and their rise slew-limited, a load cell over its ceiling (led by its
/// rate) vents its muscle, a joint outside its range turns its motor off (and with `range_vent`,
/// about to be outside, also vents the muscle that drives it further out).
struct BoardLimits {
  bool configured = false;                   ///< false: the map has no `board_limits:` entry for the joint
  double agonist_force_N = 0, antagonist_force_N = 0;          ///< load-cell ceilings
  double agonist_pressure_Pa = 0, antagonist_pressure_Pa = 0;  ///< valve setpoint ceilings
  double pressure_rise_Pa_per_s = 0;         ///< fastest rise of either valve's setpoint
  double force_lead_s = 0;                   ///< the force trip's lead: the valves' reaction time
  double motor_torque_Nm = 0;                ///< |torque| ceiling (joints with a motor channel)
  double min_angle_rad = 0, max_angle_rad = 0;  ///< the encoder's range; outside, the motor is off
  /// `range_vent:` given: (about to be) out of range also vents the muscle driving the joint out,
  /// judged on the angle led by the speed x `angle_lead_s` + speed^2 / (2 `brake_rad_per_s2`).
  bool range_vent = false;
  double angle_lead_s = 0;                   ///< the range's lead on the speed: the valves' reaction time
  double brake_rad_per_s2 = 0;               ///< the deceleration the braking muscle gives (0: no stopping distance)
  /// `speed_vent:` given (else 0): a joint whose speed, led by its acceleration x `speed_lead_s`,
  /// passes `speed_ceiling_rad_per_s` has its motor cut and the muscle driving it vented, the other kept.
  double speed_ceiling_rad_per_s = 0;
  double speed_lead_s = 0;                   ///< the speed trip's lead on the acceleration: the valves' reaction time
};

/// Every channel of one joint.
struct JointChannels {
  // AD
  AnalogChannel agonist_loadcell;        ///< load cell, N
  AnalogChannel antagonist_loadcell;     ///< load cell, N
  AnalogChannel agonist_pressure;     ///< pressure sensor, Pa (gauge)
  AnalogChannel antagonist_pressure;  ///< pressure sensor, Pa (gauge)
  AnalogChannel goniometer;           ///< optional, rad
  AnalogChannel supply_pressure;      ///< optional: the supply line at the joint's valves, Pa (gauge)
  AnalogChannel motor_torque_monitor; ///< optional: the motor driver's current monitor as torque at the joint, Nm
  // DA
  AnalogChannel agonist_valve;        ///< pressure setpoint, Pa
  AnalogChannel antagonist_valve;     ///< pressure setpoint, Pa
  AnalogChannel motor;                ///< optional: torque at the joint (after the gear), Nm
  // counter
  EncoderChannel encoder;
  EncoderChannel redundant_encoder;   ///< optional (`redundant: true`): a second encoder on the joint's axis
  BoardLimits board_limits;           ///< the board's own limits (optional section `board_limits:`)
};

class ChannelMap;

/// Reads a channel map file (YAML) for a backend whose joints are `joint_names` (in
/// io::SensorState order). Throws `config::Error` (file:line:col: key.path: reason) for anything
/// the schema in docs/channel-maps.md rejects; `std::invalid_argument` if `joint_names` is empty,
/// longer than io::kMaxJoints or has duplicates (a programming error, not the file's).
ChannelMap read_channel_map(const config::Document& doc, const std::vector<std::string>& joint_names);
/// Same, for a channel map embedded as a mapping in a larger file.
ChannelMap read_channel_map(config::Map map, const std::vector<std::string>& joint_names);

class ChannelMap {
 public:
  // --- Host side (1 kHz loop: noexcept, no allocation) ---

  /// Board sample -> SI sensor state: angles from the encoders, forces and pressures from AD.
  /// Fills `joint_count` and `joints[0..joint_count)`; leaves `time_s` and `sequence` (the
  /// backend's) alone. Returns false and leaves `out` untouched if any mapped AD channel
  /// (goniometers included) is outside its valid codes (`implausible_ad_channels() != 0`). Mapped
  /// values are finite by construction (integer inputs, finite constants checked at load); the
  /// optional supply-pressure and motor-torque-monitor signals are NaN where not mapped.
  bool decode_inputs(const BoardInputs& in, io::SensorState& out) const noexcept;
  /// Bit i set if AD channel i is mapped and its code is outside the channel's valid codes.
  std::uint16_t implausible_ad_channels(const BoardInputs& in) const noexcept;
  /// SI command -> DA codes (nearest code, clamped to 0..65535) and the enable line set active iff
  /// `enable`. Returns how many DA channels were clamped (a NaN counts, and gets the safe code).
  /// A nonzero motor command for a joint without a motor channel is ignored (not counted). If
  /// `cmd.joint_count != joint_count()` nothing of it is encoded: `out = safe_outputs()` (enable
  /// inactive) and the return is -1; the backend should refuse such a command before this.
  /// Unmapped DA channels and digital lines are 0.
  int encode_outputs(const io::Command& cmd, bool enable, BoardOutputs& out) const noexcept;
  /// True if the e-stop input line is at its active level.
  bool estop_active(const BoardInputs& in) const noexcept { return estop_.active(in.digital_in); }
  /// Goniometer angle of `joint`, rad; NaN if the joint has no goniometer (or no such joint).
  double goniometer_rad(const BoardInputs& in, int joint) const noexcept;
  bool has_goniometer(int joint) const noexcept;

  // --- Board / emulator side (the inverse maps) ---

  /// SI -> codes and counts (nearest, clamped). A joint's goniometer channel gets its `angle_rad`
  /// (the simulator has no separate goniometer). The e-stop line is set to its active level iff
  /// `estop`; unmapped AD channels and other input lines are 0.
  void encode_inputs(const io::SensorState& s, bool estop, BoardInputs& out) const noexcept;
  /// Codes -> SI command (`joint_count` set; motor torque 0 for joints without a motor).
  void decode_outputs(const BoardOutputs& out, io::Command& cmd) const noexcept;
  /// True if the enable output line is at its active level.
  bool enable_active(const BoardOutputs& out) const noexcept { return enable_.active(out.digital_out); }
  /// The outputs that make the actuators safe: valve setpoints at the code nearest 0 Pa (vent),
  /// motors at the code nearest 0 Nm, enable inactive, unmapped channels 0. Used by the board's
  /// watchdog. The reader guarantees 0 Pa and 0 Nm lie within each channel's code range.
  BoardOutputs safe_outputs() const noexcept { return safe_; }

  // --- Description (docs, tests, logs) ---

  int joint_count() const noexcept { return static_cast<int>(joint_names_.size()); }
  const std::vector<std::string>& joint_names() const noexcept { return joint_names_; }
  /// Channels of joint `i`; throws std::out_of_range unless 0 <= i < joint_count().
  const JointChannels& joint(int i) const;
  /// True if the map gives the board its own limits (`board_limits:`, then for every joint).
  bool has_board_limits() const noexcept { return joints_[0].board_limits.configured; }
  /// The e-stop input and the enable output (the board core reads the e-stop itself).
  const DigitalLine& estop_line() const noexcept { return estop_; }
  /// The rig's procedure key (`digital: procedure_key_input:`, optional): a key switch a person turns
  /// for a procedure that drives joints onto their stops; while it is active the board's range does
  /// not vent (docs/safety.md#the-boards-own-limits). No packet can set it.
  const std::optional<DigitalLine>& procedure_key_line() const noexcept { return procedure_key_; }

 private:
  friend ChannelMap read_channel_map(config::Map map, const std::vector<std::string>& joint_names);
  ChannelMap() = default;

  std::vector<std::string> joint_names_;
  std::array<JointChannels, io::kMaxJoints> joints_{};
  DigitalLine enable_;
  DigitalLine estop_;
  std::optional<DigitalLine> procedure_key_;
  BoardOutputs safe_{};
};

}  // namespace peha::mfb
