#pragma once
/// \file
/// The limits layer every command passes before it reaches a backend (SPEC §6). The safety
/// supervisor of a later issue extends it; it replaces nothing here.
///
/// Per joint, in this order:
/// 1. a non-finite pressure is replaced by the previous command, a non-finite motor torque by 0
///    (flag kNonFinite);
/// 2. joint range: outside [min_angle, max_angle] the muscle that pushes further out may not gain
///    pressure and the motor may not push further out (flag kJointRange);
/// 3. pressures: within [floor, ceiling], where the ceiling is min(supply, P that makes the muscle's
///    force ceiling by the controller's model) and the floor is the P that keeps the wire pretension
///    by that model, or 0 where the model says the muscle cannot make it (flag kPressureLimited);
/// 4. rate limits on pressures and motor torque (flag kRateLimited);
/// 5. motor torque within its rating (flag kMotorLimited).
/// noexcept and allocation-free.

#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"

#include <array>
#include <cstdint>

namespace peha::safety {

enum LimitFlag : std::uint32_t {
  kNonFinite = 1u << 0,
  kJointRange = 1u << 1,
  kPressureLimited = 1u << 2,
  kRateLimited = 1u << 3,
  kMotorLimited = 1u << 4,
};

struct JointLimits {
  models::JointModel model;             ///< the controller's model (for force ceiling/pretension)
  double supply_pressure_Pa = 0.8e6;
  double pretension_N = 20;             ///< minimum muscle force that keeps the wire taut, N
  double pressure_rate_Pa_per_s = 5e6;  ///< max |dP/dt| of a command
  double motor_rate_Nm_per_s = 500;     ///< max |d tau/dt| of the motor command
  double min_angle_rad = -1;
  double max_angle_rad = 1;
};

struct LimitsModel {
  int joint_count = 0;
  std::array<JointLimits, io::kMaxJoints> joints{};
  double period_s = 1e-3;
};

struct LimitsData {
  io::Command previous{};
  bool has_previous = false;
  std::array<std::uint32_t, io::kMaxJoints> flags{};  ///< flags of the last call, per joint
  std::array<std::uint64_t, 5> counts{};              ///< how often each flag fired, by bit index
};

/// Limits `command` in place against `state`. Returns the or of all joints' flags.
std::uint32_t apply_limits(const LimitsModel& model, LimitsData& data, const io::SensorState& state,
                           io::Command& command) noexcept;

}  // namespace peha::safety
