#include "peha/mfb/channel_map.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string_view>
#include <utility>

namespace peha::mfb {
namespace {

struct Unit {
  std::string_view name;
  double to_SI;  ///< SI value of one of this unit
};

constexpr Unit kForceUnits[] = {{"N", 1.0}};
constexpr Unit kPressureUnits[] = {{"Pa", 1.0}, {"kPa", 1e3}, {"MPa", 1e6}, {"bar", 1e5}};
constexpr Unit kTorqueUnits[] = {{"Nm", 1.0}};
constexpr Unit kAngleUnits[] = {{"rad", 1.0}, {"deg", models::kRadPerDeg}};

struct Dimension {
  std::string_view what;  ///< for messages: "a pressure unit"
  std::span<const Unit> units;
};

constexpr Dimension kForce{"a force unit", kForceUnits};
constexpr Dimension kPressure{"a pressure unit", kPressureUnits};
constexpr Dimension kTorque{"a torque unit", kTorqueUnits};
constexpr Dimension kAngle{"an angle unit", kAngleUnits};

/// A quantity a joint's AD or DA channel can carry, and where it lives in `JointChannels`.
struct Quantity {
  std::string_view name;
  const Dimension* dimension;
  bool required;
  AnalogChannel JointChannels::*member;
};

const Quantity kAdQuantities[] = {
    {"agonist_loadcell", &kForce, true, &JointChannels::agonist_loadcell},
    {"antagonist_loadcell", &kForce, true, &JointChannels::antagonist_loadcell},
    {"agonist_pressure", &kPressure, true, &JointChannels::agonist_pressure},
    {"antagonist_pressure", &kPressure, true, &JointChannels::antagonist_pressure},
    {"goniometer", &kAngle, false, &JointChannels::goniometer},
    {"supply_pressure", &kPressure, false, &JointChannels::supply_pressure},
    {"motor_torque_monitor", &kTorque, false, &JointChannels::motor_torque_monitor},
};

const Quantity kDaQuantities[] = {
    {"agonist_valve", &kPressure, true, &JointChannels::agonist_valve},
    {"antagonist_valve", &kPressure, true, &JointChannels::antagonist_valve},
    {"motor", &kTorque, false, &JointChannels::motor},
};

/// The AD side or the DA side of the board.
struct AnalogKind {
  std::string_view key;    ///< list key in the file
  std::string_view board;  ///< "AD" / "DA" in messages
  std::string_view what;   ///< "analog input" / "analog output" in messages
  int channel_count;
  std::span<const Quantity> quantities;
  bool input;
};

const AnalogKind kAnalogInputs{"analog_inputs", "AD", "analog input", kAdChannels, kAdQuantities, true};
const AnalogKind kAnalogOutputs{"analog_outputs", "DA", "analog output", kDaChannels, kDaQuantities, false};

/// Largest |scale| or |offset| accepted, in the declared unit; keeps every SI value finite.
constexpr double kMaxMagnitude = 1e9;

int find_joint(const std::vector<std::string>& names, std::string_view joint) {
  const auto it = std::find(names.begin(), names.end(), joint);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

[[noreturn]] void fail_unknown_joint(const config::Map& item, std::string_view key, std::string_view joint,
                                     std::string_view in, const std::vector<std::string>& names) {
  item.fail(key, fmt::format("unknown joint '{}'{}; the backend's joints are {}", joint, in,
                             fmt::join(names, ", ")));
}

/// Splits "<joint>.<quantity>" and looks both up.
std::pair<int, const Quantity*> parse_signal(const config::Map& item, const std::string& signal,
                                             const AnalogKind& kind, const std::vector<std::string>& names) {
  const auto dot = signal.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == signal.size()) {
    item.fail("signal", fmt::format("expected '<joint>.<quantity>', found '{}'", signal));
  }
  const std::string_view joint = std::string_view(signal).substr(0, dot);
  const std::string_view quantity = std::string_view(signal).substr(dot + 1);
  const int j = find_joint(names, joint);
  if (j < 0) fail_unknown_joint(item, "signal", joint, fmt::format(" in '{}'", signal), names);
  for (const Quantity& q : kind.quantities) {
    if (q.name == quantity) return {j, &q};
  }
  std::vector<std::string_view> options;
  for (const Quantity& q : kind.quantities) options.push_back(q.name);
  item.fail("signal", fmt::format("unknown {} quantity '{}' in '{}'; expected one of {}", kind.what, quantity,
                                  signal, fmt::join(options, ", ")));
}

double unit_to_SI(const config::Map& item, const std::string& unit, const Quantity& q, const std::string& signal) {
  for (const Unit& u : q.dimension->units) {
    if (u.name == unit) return u.to_SI;
  }
  std::vector<std::string_view> options;
  for (const Unit& u : q.dimension->units) options.push_back(u.name);
  item.fail("unit", fmt::format("expected {} ({}) for '{}', found '{}'", q.dimension->what, fmt::join(options, ", "),
                                signal, unit));
}

/// `scale` + `offset`, or `range: [value at code 0, value at code 65535]`, in the declared unit.
/// Returns the key the conversion came from (for later messages about it).
std::string_view read_linear(config::Map& item, double& scale, double& offset) {
  const bool has_range = item.has("range");
  if (has_range && (item.has("scale") || item.has("offset"))) {
    item.fail("range", "give either range or scale and offset, not both");
  }
  if (has_range) {
    const std::vector<double> r = item.numbers("range", {-kMaxMagnitude, kMaxMagnitude}, 2, 2);
    if (r[0] == r[1]) item.fail("range", fmt::format("the values at code 0 and code {} must differ, found {} twice", kMaxCode, r[0]));
    offset = r[0];
    scale = (r[1] - r[0]) / kMaxCode;
    return "range";
  }
  if (!item.has("scale")) item.fail("", "expected scale and offset (physical = offset + scale * code), or range");
  scale = item.number("scale", {-kMaxMagnitude, kMaxMagnitude});
  if (scale == 0.0) item.fail("scale", "expected a nonzero number (physical = offset + scale * code), found 0");
  offset = item.number("offset", {-kMaxMagnitude, kMaxMagnitude});
  return "offset";
}

void read_valid_codes(config::Map& item, AnalogChannel& ch) {
  if (!item.has("valid_codes")) return;  // every code is plausible
  const std::vector<double> v = item.numbers("valid_codes", {0.0, static_cast<double>(kMaxCode)}, 2, 2);
  if (std::floor(v[0]) != v[0] || std::floor(v[1]) != v[1] || v[0] >= v[1]) {
    item.fail("valid_codes", fmt::format("expected two integer codes [min, max] with min < max, found [{}, {}]", v[0], v[1]));
  }
  ch.min_valid_code = static_cast<std::uint16_t>(v[0]);
  ch.max_valid_code = static_cast<std::uint16_t>(v[1]);
}

void read_analog(config::Map& root, const AnalogKind& kind, const std::vector<std::string>& names,
                 std::array<JointChannels, io::kMaxJoints>& joints) {
  std::array<std::string, kAdChannels> used_by;  // signal on each board channel so far
  for (config::Map item : root.maps(kind.key, 1, static_cast<std::size_t>(kind.channel_count))) {
    const int channel = static_cast<int>(item.integer("channel", 0, kind.channel_count - 1));
    const std::string signal = item.string("signal");
    const auto [joint, quantity] = parse_signal(item, signal, kind, names);
    if (!used_by[static_cast<std::size_t>(channel)].empty()) {
      item.fail("channel", fmt::format("{} channel {} is already used by '{}'", kind.board, channel,
                                       used_by[static_cast<std::size_t>(channel)]));
    }
    AnalogChannel& ch = joints[static_cast<std::size_t>(joint)].*(quantity->member);
    if (ch.mapped()) {
      item.fail("signal", fmt::format("'{}' is mapped twice (first to {} channel {})", signal, kind.board, ch.channel));
    }
    used_by[static_cast<std::size_t>(channel)] = signal;
    ch.channel = channel;
    ch.unit = item.string("unit");
    const double to_SI = unit_to_SI(item, ch.unit, *quantity, signal);
    double scale = 0, offset = 0;
    const std::string_view conversion_key = read_linear(item, scale, offset);
    ch.scale_SI = scale * to_SI;
    ch.offset_SI = offset * to_SI;
    if (kind.input) {
      read_valid_codes(item, ch);
    } else {
      // The watchdog's safe outputs (vent, no torque) must be a code this channel can send.
      const double zero_code = -offset / scale;
      if (!(zero_code >= 0.0 && zero_code <= kMaxCode)) {
        item.fail(conversion_key,
                  fmt::format("0 {} must be within the channel's range [{:g}, {:g}] {} (the safe output: vent / no torque)",
                              ch.unit, std::min(offset, offset + scale * kMaxCode),
                              std::max(offset, offset + scale * kMaxCode), ch.unit));
      }
    }
    item.finish();
  }
  for (std::size_t j = 0; j < names.size(); ++j) {
    for (const Quantity& q : kind.quantities) {
      if (q.required && !(joints[j].*(q.member)).mapped()) {
        root.fail(kind.key, fmt::format("no {} channel for '{}.{}' (every joint needs {})", kind.board, names[j], q.name,
                                        kind.input ? "both forces and both pressures" : "both valves"));
      }
    }
  }
}

void read_encoders(config::Map& root, const std::vector<std::string>& names,
                   std::array<JointChannels, io::kMaxJoints>& joints) {
  std::array<int, kEncoderChannels> used_by;  // joint on each counter so far
  used_by.fill(-1);
  for (config::Map item : root.maps("encoders", 1, kEncoderChannels)) {
    const int channel = static_cast<int>(item.integer("channel", 0, kEncoderChannels - 1));
    const std::string name = item.string("joint");
    const int joint = find_joint(names, name);
    if (joint < 0) fail_unknown_joint(item, "joint", name, "", names);
    if (used_by[static_cast<std::size_t>(channel)] >= 0) {
      item.fail("channel", fmt::format("encoder channel {} is already used by joint '{}'", channel,
                                       names[static_cast<std::size_t>(used_by[static_cast<std::size_t>(channel)])]));
    }
    const bool redundant = item.boolean_or("redundant", false);
    EncoderChannel& e = redundant ? joints[static_cast<std::size_t>(joint)].redundant_encoder : joints[static_cast<std::size_t>(joint)].encoder;
    if (e.channel >= 0) {
      item.fail("joint", fmt::format("joint '{}' already has {} encoder channel {} (one, and at most one redundant, per joint)", name,
                                     redundant ? "a redundant" : "its", e.channel));
    }
    used_by[static_cast<std::size_t>(channel)] = joint;
    e.channel = channel;
    e.counts_per_rev = item.number("counts_per_rev", {1.0, 1e9});
    e.gear = item.number("gear", {1e-3, 1e6});
    e.sign = static_cast<int>(item.integer("sign", -1, 1));
    if (e.sign == 0) item.fail("sign", "expected +1 or -1, found 0");
    e.offset_rad = models::deg_to_rad(item.number("offset_deg", {-360.0, 360.0}));
    e.rad_per_count = e.sign * 2.0 * std::numbers::pi / (e.counts_per_rev * e.gear);
    item.finish();
  }
  for (std::size_t j = 0; j < names.size(); ++j) {
    if (joints[j].encoder.channel < 0) {
      root.fail("encoders", fmt::format("no encoder for joint '{}' (every joint needs exactly one that is not redundant)", names[j]));
    }
  }
}

/// `board_limits:` (optional): one entry per joint, every joint once.
void read_board_limits(config::Map& root, const std::vector<std::string>& names, std::array<JointChannels, io::kMaxJoints>& joints) {
  if (!root.has("board_limits")) return;
  for (config::Map item : root.maps("board_limits", names.size(), names.size())) {
    const std::string name = item.string("joint");
    const int joint = find_joint(names, name);
    if (joint < 0) fail_unknown_joint(item, "joint", name, "", names);
    JointChannels& c = joints[static_cast<std::size_t>(joint)];
    BoardLimits& l = c.board_limits;
    if (l.configured) item.fail("joint", fmt::format("joint '{}' has board limits twice", name));
    l.configured = true;
    l.agonist_force_N = item.number("agonist_force_N", {1.0, 1e5});
    l.antagonist_force_N = item.number("antagonist_force_N", {1.0, 1e5});
    l.agonist_pressure_Pa = item.number("agonist_pressure_MPa", {0.01, 10.0}) * 1e6;
    l.antagonist_pressure_Pa = item.number("antagonist_pressure_MPa", {0.01, 10.0}) * 1e6;
    l.pressure_rise_Pa_per_s = item.number("pressure_rise_MPa_per_s", {0.01, 100.0}) * 1e6;
    l.force_lead_s = item.number("force_lead_ms", {0.0, 1000.0}) * 1e-3;
    if (c.motor.mapped()) {
      l.motor_torque_Nm = item.number("motor_torque_Nm", {1e-3, 1e4});
    } else if (item.has("motor_torque_Nm")) {
      item.fail("motor_torque_Nm", fmt::format("joint '{}' has no motor channel", name));
    }
    const std::vector<double> range = item.numbers("angle_deg", {-360.0, 360.0}, 2, 2);
    if (!(range[0] < range[1])) item.fail("angle_deg", fmt::format("expected [min, max] with min < max, found [{}, {}]", range[0], range[1]));
    l.min_angle_rad = models::deg_to_rad(range[0]);
    l.max_angle_rad = models::deg_to_rad(range[1]);
    if (item.has("range_vent")) {
      config::Map vent = item.map("range_vent");
      l.range_vent = true;
      l.angle_lead_s = vent.number("lead_ms", {0.0, 1000.0}) * 1e-3;
      l.brake_rad_per_s2 = models::deg_to_rad(vent.number("brake_deg_per_s2", {1.0, 1e6}));
      vent.finish();
    }
    if (item.has("speed_vent")) {
      config::Map vent = item.map("speed_vent");
      l.speed_ceiling_rad_per_s = models::deg_to_rad(vent.number("ceiling_deg_per_s", {1.0, 1e5}));
      l.speed_lead_s = vent.number("lead_ms", {0.0, 1000.0}) * 1e-3;
      vent.finish();
    }
    item.finish();
  }
}

DigitalLine read_line(config::Map map) {
  DigitalLine d;
  d.line = static_cast<int>(map.integer("line", 0, kDigitalLines - 1));
  d.active_high = map.choice("active", {"high", "low"}) == "high";
  map.finish();
  return d;
}

}  // namespace

std::uint16_t AnalogChannel::to_code(double value_SI, bool& clamped) const noexcept {
  double code = std::round((value_SI - offset_SI) / scale_SI);
  if (std::isnan(code)) {
    clamped = true;
    code = std::round(-offset_SI / scale_SI);
  }
  if (code < 0.0) {
    clamped = true;
    return 0;
  }
  if (code > kMaxCode) {
    clamped = true;
    return kMaxCode;
  }
  return static_cast<std::uint16_t>(code);
}

double AnalogChannel::min_si() const noexcept { return std::min(to_si(min_valid_code), to_si(max_valid_code)); }
double AnalogChannel::max_si() const noexcept { return std::max(to_si(min_valid_code), to_si(max_valid_code)); }

std::int32_t EncoderChannel::to_counts(double angle_rad) const noexcept {
  const double counts = std::round((angle_rad - offset_rad) / rad_per_count);
  if (std::isnan(counts)) return 0;
  constexpr double kMin = std::numeric_limits<std::int32_t>::min();
  constexpr double kMax = std::numeric_limits<std::int32_t>::max();
  return static_cast<std::int32_t>(std::clamp(counts, kMin, kMax));
}

void DigitalLine::set(std::uint8_t& byte, bool active) const noexcept {
  const auto mask = static_cast<std::uint8_t>(1u << line);
  const bool high = active == active_high;
  byte = high ? static_cast<std::uint8_t>(byte | mask) : static_cast<std::uint8_t>(byte & ~mask);
}

ChannelMap read_channel_map(const config::Document& doc, const std::vector<std::string>& joint_names) {
  return read_channel_map(doc.root(), joint_names);
}

ChannelMap read_channel_map(config::Map map, const std::vector<std::string>& joint_names) {
  if (joint_names.empty() || joint_names.size() > static_cast<std::size_t>(io::kMaxJoints)) {
    throw std::invalid_argument(fmt::format("channel map: expected 1 to {} joint names, found {}", io::kMaxJoints,
                                            joint_names.size()));
  }
  for (std::size_t j = 0; j < joint_names.size(); ++j) {
    if (find_joint(joint_names, joint_names[j]) != static_cast<int>(j)) {
      throw std::invalid_argument(fmt::format("channel map: joint name '{}' appears twice", joint_names[j]));
    }
  }
  ChannelMap m;
  m.joint_names_ = joint_names;
  read_analog(map, kAnalogInputs, joint_names, m.joints_);
  read_analog(map, kAnalogOutputs, joint_names, m.joints_);
  read_encoders(map, joint_names, m.joints_);
  read_board_limits(map, joint_names, m.joints_);
  config::Map digital = map.map("digital");
  m.enable_ = read_line(digital.map("enable_output"));
  m.estop_ = read_line(digital.map("estop_input"));
  if (digital.has("procedure_key_input")) {
    m.procedure_key_ = read_line(digital.map("procedure_key_input"));
    if (m.procedure_key_->line == m.estop_.line) {
      digital.fail("procedure_key_input", fmt::format("line {} is the e-stop's: the key needs an input of its own", m.procedure_key_->line));
    }
  }
  digital.finish();
  map.finish();

  for (int j = 0; j < m.joint_count(); ++j) {
    for (const Quantity& q : kDaQuantities) {
      const AnalogChannel& ch = m.joints_[static_cast<std::size_t>(j)].*(q.member);
      bool clamped = false;  // cannot happen: the reader checked that 0 is within range
      if (ch.mapped()) m.safe_.da[static_cast<std::size_t>(ch.channel)] = ch.to_code(0.0, clamped);
    }
  }
  m.enable_.set(m.safe_.digital_out, false);
  return m;
}

const JointChannels& ChannelMap::joint(int i) const {
  if (i < 0 || i >= joint_count()) {
    throw std::out_of_range(fmt::format("channel map: no joint {} (the map has {})", i, joint_count()));
  }
  return joints_[static_cast<std::size_t>(i)];
}

std::uint16_t ChannelMap::implausible_ad_channels(const BoardInputs& in) const noexcept {
  std::uint16_t mask = 0;
  for (int j = 0; j < joint_count(); ++j) {
    for (const Quantity& q : kAdQuantities) {
      const AnalogChannel& ch = joints_[static_cast<std::size_t>(j)].*(q.member);
      if (!ch.mapped()) continue;
      const std::uint16_t code = in.ad[static_cast<std::size_t>(ch.channel)];
      if (code < ch.min_valid_code || code > ch.max_valid_code) mask = static_cast<std::uint16_t>(mask | (1u << ch.channel));
    }
  }
  return mask;
}

bool ChannelMap::decode_inputs(const BoardInputs& in, io::SensorState& out) const noexcept {
  if (implausible_ad_channels(in) != 0) return false;
  const auto ad = [&](const AnalogChannel& ch) { return ch.to_si(in.ad[static_cast<std::size_t>(ch.channel)]); };
  out.joint_count = joint_count();
  for (int j = 0; j < joint_count(); ++j) {
    const JointChannels& c = joints_[static_cast<std::size_t>(j)];
    io::JointSensors& s = out.joints[static_cast<std::size_t>(j)];
    s.angle_rad = c.encoder.to_rad(in.encoder[static_cast<std::size_t>(c.encoder.channel)]);
    s.agonist_loadcell_N = ad(c.agonist_loadcell);
    s.antagonist_loadcell_N = ad(c.antagonist_loadcell);
    s.agonist_pressure_Pa = ad(c.agonist_pressure);
    s.antagonist_pressure_Pa = ad(c.antagonist_pressure);
    s.supply_pressure_Pa = c.supply_pressure.mapped() ? ad(c.supply_pressure) : std::numeric_limits<double>::quiet_NaN();
    s.motor_torque_Nm = c.motor_torque_monitor.mapped() ? ad(c.motor_torque_monitor) : std::numeric_limits<double>::quiet_NaN();
    s.redundant_angle_rad = c.redundant_encoder.channel >= 0
                                ? c.redundant_encoder.to_rad(in.encoder[static_cast<std::size_t>(c.redundant_encoder.channel)])
                                : std::numeric_limits<double>::quiet_NaN();
  }
  return true;
}

int ChannelMap::encode_outputs(const io::Command& cmd, bool enable, BoardOutputs& out) const noexcept {
  if (cmd.joint_count != joint_count()) {
    out = safe_;
    return -1;
  }
  out = BoardOutputs{};
  int clamped = 0;
  const auto put = [&](const AnalogChannel& ch, double value_SI) {
    if (!ch.mapped()) return;  // e.g. the motor of a joint without one: its command is ignored
    bool c = false;
    out.da[static_cast<std::size_t>(ch.channel)] = ch.to_code(value_SI, c);
    clamped += c ? 1 : 0;
  };
  for (int j = 0; j < joint_count(); ++j) {
    const JointChannels& c = joints_[static_cast<std::size_t>(j)];
    const io::JointCommand& jc = cmd.joints[static_cast<std::size_t>(j)];
    put(c.agonist_valve, jc.agonist_pressure_Pa);
    put(c.antagonist_valve, jc.antagonist_pressure_Pa);
    put(c.motor, jc.motor_torque_Nm);
  }
  enable_.set(out.digital_out, enable);
  return clamped;
}

double ChannelMap::goniometer_rad(const BoardInputs& in, int joint) const noexcept {
  if (!has_goniometer(joint)) return std::numeric_limits<double>::quiet_NaN();
  const AnalogChannel& ch = joints_[static_cast<std::size_t>(joint)].goniometer;
  return ch.to_si(in.ad[static_cast<std::size_t>(ch.channel)]);
}

bool ChannelMap::has_goniometer(int joint) const noexcept {
  return joint >= 0 && joint < joint_count() && joints_[static_cast<std::size_t>(joint)].goniometer.mapped();
}

void ChannelMap::encode_inputs(const io::SensorState& s, bool estop, BoardInputs& out) const noexcept {
  out = BoardInputs{};
  bool saturated = false;  // a sensor at its rail reads the rail: nothing to report here
  const auto put = [&](const AnalogChannel& ch, double value_SI) {
    if (ch.mapped()) out.ad[static_cast<std::size_t>(ch.channel)] = ch.to_code(value_SI, saturated);
  };
  for (int j = 0; j < joint_count(); ++j) {
    const JointChannels& c = joints_[static_cast<std::size_t>(j)];
    const io::JointSensors& js = s.joints[static_cast<std::size_t>(j)];
    put(c.agonist_loadcell, js.agonist_loadcell_N);
    put(c.antagonist_loadcell, js.antagonist_loadcell_N);
    put(c.agonist_pressure, js.agonist_pressure_Pa);
    put(c.antagonist_pressure, js.antagonist_pressure_Pa);
    put(c.goniometer, js.angle_rad);
    put(c.supply_pressure, js.supply_pressure_Pa);
    put(c.motor_torque_monitor, js.motor_torque_Nm);
    out.encoder[static_cast<std::size_t>(c.encoder.channel)] = c.encoder.to_counts(js.angle_rad);
    if (c.redundant_encoder.channel >= 0) {
      out.encoder[static_cast<std::size_t>(c.redundant_encoder.channel)] = c.redundant_encoder.to_counts(js.redundant_angle_rad);
    }
  }
  estop_.set(out.digital_in, estop);
}

void ChannelMap::decode_outputs(const BoardOutputs& out, io::Command& cmd) const noexcept {
  const auto da = [&](const AnalogChannel& ch) {
    return ch.mapped() ? ch.to_si(out.da[static_cast<std::size_t>(ch.channel)]) : 0.0;
  };
  cmd.joint_count = joint_count();
  for (int j = 0; j < joint_count(); ++j) {
    const JointChannels& c = joints_[static_cast<std::size_t>(j)];
    io::JointCommand& jc = cmd.joints[static_cast<std::size_t>(j)];
    jc.agonist_pressure_Pa = da(c.agonist_valve);
    jc.antagonist_pressure_Pa = da(c.antagonist_valve);
    jc.motor_torque_Nm = da(c.motor);
  }
}

}  // namespace peha::mfb
