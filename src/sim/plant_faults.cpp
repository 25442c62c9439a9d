#include "peha/sim/plant_faults.hpp"
#include "peha/sim/peha_joint_plant.hpp"

#include <fmt/format.h>

#include <charconv>
#include <optional>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace peha::sim {
namespace {

constexpr std::array<const char*, kFaultKindCount> kNames = {
    "loadcell_stuck", "loadcell_bias",  "loadcell_disconnected", "loadcell_saturated", "encoder_jump",  "encoder_frozen",
    "pressure_sensor_fail", "supply_zero", "supply_half", "valve_stuck_open", "valve_stuck_closed", "wire_break",
    "wire_slip", "motor_fault", "controller_nan", "estop", "loadcell_drift", "state_loss", "board_reboot"};

std::optional<FaultKind> kind_named(std::string_view name) {
  for (int i = 0; i < kFaultKindCount; ++i) {
    if (name == kNames[static_cast<std::size_t>(i)]) return static_cast<FaultKind>(i);
  }
  return std::nullopt;
}

int muscle_named(std::string_view name) {
  if (name == "agonist") return 0;
  if (name == "antagonist") return 1;
  return -1;
}

int joint_named(std::string_view name, const std::vector<std::string>& joints) {
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (joints[i] == name) return static_cast<int>(i);
  }
  return -1;
}

std::string joint_list(const std::vector<std::string>& joints) {
  std::string s;
  for (const auto& j : joints) s += (s.empty() ? "" : "|") + j;
  return s;
}

double to_number(std::string_view text, const char* what, std::string_view spec) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) {
    throw std::invalid_argument(fmt::format("--fault {}: {} must be a number, found '{}'", spec, what, text));
  }
  return v;
}

}  // namespace

const char* fault_kind_name(FaultKind kind) noexcept { return kNames[static_cast<std::size_t>(kind)]; }

const std::array<FaultKind, kFaultKindCount>& all_fault_kinds() noexcept {
  static const std::array<FaultKind, kFaultKindCount> kinds = [] {
    std::array<FaultKind, kFaultKindCount> k{};
    for (int i = 0; i < kFaultKindCount; ++i) k[static_cast<std::size_t>(i)] = static_cast<FaultKind>(i);
    return k;
  }();
  return kinds;
}

bool fault_targets_muscle(FaultKind kind) noexcept {
  switch (kind) {
    case FaultKind::kLoadcellStuck:
    case FaultKind::kLoadcellBias:
    case FaultKind::kLoadcellDrift:
    case FaultKind::kLoadcellDisconnected:
    case FaultKind::kLoadcellSaturated:
    case FaultKind::kPressureSensorFail:
    case FaultKind::kValveStuckOpen:
    case FaultKind::kValveStuckClosed:
    case FaultKind::kWireBreak:
    case FaultKind::kWireSlip:
      return true;
    default:
      return false;
  }
}

bool is_outage(FaultKind kind) noexcept { return kind == FaultKind::kStateLoss || kind == FaultKind::kBoardReboot; }

bool fault_takes_value(FaultKind kind) noexcept {
  return kind == FaultKind::kLoadcellBias || kind == FaultKind::kLoadcellDrift || kind == FaultKind::kEncoderJump ||
         kind == FaultKind::kWireSlip || is_outage(kind);
}

double fault_default_value(FaultKind kind) noexcept {
  switch (kind) {
    case FaultKind::kLoadcellBias: return 400.0;  // N
    case FaultKind::kLoadcellDrift: return 10.0;  // N/s
    case FaultKind::kEncoderJump: return 10.0;    // deg
    case FaultKind::kWireSlip: return 5.0;        // mm
    case FaultKind::kStateLoss:
    case FaultKind::kBoardReboot: return 2.5;     // s: issue 29's outages lasted 2-4 s
    default: return 0.0;
  }
}

std::string fault_kind_list() {
  std::string s;
  for (const char* n : kNames) s += (s.empty() ? "" : "|") + std::string(n);
  return s;
}

PlantFault parse_fault_spec(std::string_view spec, const std::vector<std::string>& joint_names, double duration_s) {
  const std::string_view whole = spec;
  const auto at = spec.find('@');
  if (at == std::string_view::npos) {
    throw std::invalid_argument(fmt::format("--fault {}: expected KIND@T[:TARGET[=VALUE]] (KIND one of {})", whole, fault_kind_list()));
  }
  const auto kind = kind_named(spec.substr(0, at));
  if (!kind) throw std::invalid_argument(fmt::format("--fault {}: kind must be one of {}, found '{}'", whole, fault_kind_list(), spec.substr(0, at)));
  PlantFault f;
  f.kind = *kind;
  f.value = fault_default_value(f.kind);
  spec.remove_prefix(at + 1);
  const auto colon = spec.find(':');
  std::string_view t = spec.substr(0, colon);
  if (!t.empty() && t.back() == 's') t.remove_suffix(1);
  f.time_s = to_number(t, "T (seconds)", whole);
  if (f.time_s < 0 || f.time_s > duration_s) {
    throw std::invalid_argument(fmt::format("--fault {}: T must be within [0, {}] s (the run's duration), found {}", whole, duration_s, f.time_s));
  }
  if (colon == std::string_view::npos) {
    if (fault_targets_muscle(f.kind)) {
      throw std::invalid_argument(fmt::format("--fault {}: {} hits one muscle: give :[JOINT.]agonist|antagonist", whole, fault_kind_name(f.kind)));
    }
    return f;
  }
  std::string_view target = spec.substr(colon + 1);
  const auto eq = target.find('=');
  if (eq != std::string_view::npos) {
    if (!fault_takes_value(f.kind)) throw std::invalid_argument(fmt::format("--fault {}: {} takes no =VALUE", whole, fault_kind_name(f.kind)));
    f.value = to_number(target.substr(eq + 1), "VALUE", whole);
    target = target.substr(0, eq);
  }
  std::string_view joint = target, muscle;
  if (const auto dot = target.find('.'); dot != std::string_view::npos) {
    joint = target.substr(0, dot);
    muscle = target.substr(dot + 1);
  } else if (muscle_named(target) >= 0) {
    joint = joint_names.empty() ? std::string_view() : std::string_view(joint_names.front());
    muscle = target;
  }
  f.joint = joint_named(joint, joint_names);
  if (f.joint < 0) throw std::invalid_argument(fmt::format("--fault {}: joint must be one of {}, found '{}'", whole, joint_list(joint_names), joint));
  if (fault_targets_muscle(f.kind)) {
    f.muscle = muscle_named(muscle);
    if (f.muscle < 0) throw std::invalid_argument(fmt::format("--fault {}: muscle must be agonist|antagonist, found '{}'", whole, muscle));
  } else if (!muscle.empty()) {
    throw std::invalid_argument(fmt::format("--fault {}: {} hits a whole joint: give no muscle", whole, fault_kind_name(f.kind)));
  }
  return f;
}

std::vector<PlantFault> read_plant_faults(config::Map& root, const std::vector<std::string>& joint_names, double duration_s) {
  std::vector<PlantFault> faults;
  if (!root.has("faults")) return faults;
  std::vector<std::string> kinds(kNames.begin(), kNames.end());
  std::vector<std::string> muscles = {"agonist", "antagonist"};
  for (config::Map m : root.maps("faults", 0, 64)) {
    PlantFault f;
    f.kind = *kind_named(m.choice("kind", kinds));
    f.time_s = m.number("time_s", {0.0, duration_s});
    f.joint = m.has("joint") ? joint_named(m.choice("joint", joint_names), joint_names) : 0;
    if (fault_targets_muscle(f.kind)) f.muscle = muscle_named(m.choice("muscle", muscles));
    f.value = fault_takes_value(f.kind) ? m.number_or("value", fault_default_value(f.kind), {-1e4, 1e4}) : 0.0;
    m.finish();
    faults.push_back(f);
  }
  return faults;
}

void apply_joint_fault(const PlantFault& f, JointFaultState& j) noexcept {
  const auto m = static_cast<std::size_t>(f.muscle == 1 ? 1 : 0);
  switch (f.kind) {
    case FaultKind::kLoadcellStuck: j.loadcell_stuck[m] = true; break;
    case FaultKind::kLoadcellBias: j.loadcell_bias_N[m] += f.value; break;
    case FaultKind::kLoadcellDrift:
      j.loadcell_drift_N_per_s[m] = f.value;
      j.loadcell_drift_since_s[m] = f.time_s;
      break;
    case FaultKind::kLoadcellDisconnected: j.loadcell_disconnected[m] = true; break;
    case FaultKind::kLoadcellSaturated: j.loadcell_saturated[m] = true; break;
    case FaultKind::kPressureSensorFail: j.pressure_sensor_failed[m] = true; break;
    case FaultKind::kSupplyZero: j.supply_scale = 0.0; break;
    case FaultKind::kSupplyHalf: j.supply_scale = std::min(j.supply_scale, 0.5); break;
    case FaultKind::kValveStuckOpen: j.valve_stuck_open[m] = true; break;
    case FaultKind::kValveStuckClosed: j.valve_stuck_closed[m] = true; break;
    case FaultKind::kWireBreak: j.wire_broken[m] = true; break;
    case FaultKind::kWireSlip: j.wire_slip_m[m] += f.value * 1e-3; break;
    case FaultKind::kMotorFault: j.motor_failed = true; break;
    default: break;
  }
}

void advance_joint_faults(double t_s, JointFaultState& j) noexcept {
  for (int m = 0; m < 2; ++m) {
    if (j.loadcell_drift_N_per_s[m] != 0.0) j.loadcell_drift_N[m] = j.loadcell_drift_N_per_s[m] * std::max(0.0, t_s - j.loadcell_drift_since_s[m]);
  }
}

ControllerNanInjection::ControllerNanInjection(const std::vector<PlantFault>& faults) noexcept {
  from_s_.fill(std::numeric_limits<double>::infinity());
  for (const PlantFault& f : faults) {
    if (f.kind == FaultKind::kControllerNan && f.joint >= 0 && f.joint < io::kMaxJoints) {
      double& from = from_s_[static_cast<std::size_t>(f.joint)];
      from = std::min(from, f.time_s);
    }
  }
}

void ControllerNanInjection::apply(double t_s, io::Command& command) const noexcept {
  for (std::size_t j = 0; j < from_s_.size(); ++j) {
    if (t_s + 1e-9 >= from_s_[j]) command.joints[j].agonist_pressure_Pa = std::numeric_limits<double>::quiet_NaN();
  }
}

std::string describe(const PlantFault& f, const std::vector<std::string>& joint_names) {
  const std::string joint = f.joint >= 0 && static_cast<std::size_t>(f.joint) < joint_names.size() ? joint_names[static_cast<std::size_t>(f.joint)] : "?";
  std::string s = fmt::format("{}@{}s {}", fault_kind_name(f.kind), f.time_s, joint);
  if (fault_targets_muscle(f.kind)) s += f.muscle == 0 ? ".agonist" : ".antagonist";
  if (fault_takes_value(f.kind)) s += fmt::format("={}", f.value);
  return s;
}

}  // namespace peha::sim
