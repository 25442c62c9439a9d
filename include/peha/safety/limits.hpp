#pragma once
/// \file
/// The limits layer every command passes before it reaches a backend. It sits at the backend
/// boundary (safety::LimitedBackend wraps the backend and applies it in write()), so no experiment
/// can send a command around it.
///
/// Per joint, in this order:
/// 1. a non-finite pressure is replaced by the previous command, a non-finite motor torque by 0
///    (flag kNonFinite);
/// 2. joint range: outside [min_angle, max_angle] the muscle that pushes further out may not gain
///    pressure and the motor may not push further out (flag kJointRange);
/// 3. pressures: within [floor, ceiling], where the ceiling is min(supply, P that makes the muscle's
///    force ceiling by the controller's pressure model) and the floor is the P that keeps the wire
///    pretension by that model, or 0 where the model says the muscle cannot make it (flag
///    kPressureLimited). The pressure model is models::muscle_pressure - the same one the allocation
///    uses, learned residual (SPGP) included - and supply, pretension and force ceilings are the
///    joint set-up's (models::JointModel), the very object the controller was built from. The band
///    depends only on the joint set-up and the muscle's contraction, so it is computed once per
///    muscle and contraction and reused (LimitsData::bands) while the encoder reads the same angle:
///    the same inputs, the same bits;
/// 4. rate limits on pressures and motor torque (flag kRateLimited);
/// 5. motor torque within its rating (flag kMotorLimited).
/// noexcept and allocation-free.

#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"
#include "peha/safety/fault_monitor.hpp"

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

/// What the limits add to a joint set-up: rates and range.
struct JointLimits {
  double pressure_rate_Pa_per_s = 5e6;  ///< max |dP/dt| of a command
  double motor_rate_Nm_per_s = 500;     ///< max |d tau/dt| of the motor command
  double min_angle_rad = -1;
  double max_angle_rad = 1;
};

struct LimitsModel {
  int joint_count = 0;
  std::array<JointLimits, io::kMaxJoints> joints{};
  double period_s = 1e-3;
  MonitorParams monitor;  ///< the supervisor's plausibility checks at the same boundary (fault_monitor.hpp)
  /// Tests and benchmarks only: a deliberately broken supervisor (a check off, a wrong safe state, the
  /// governor's old integral). No scenario reads or writes it; the default is the designed supervisor.
  CheckOverrides test_overrides;
};

/// The joint set-ups a limits pass reads (force ceilings, supply, pretension, pressure model, motor
/// rating): pointers to the models the controller runs with, per io joint; non-owning.
using JointModels = std::array<const models::JointModel*, io::kMaxJoints>;

/// A muscle's pressure band as last computed: for which joint set-up and contraction (bit pattern).
struct PressureBandMemo {
  const models::JointModel* joint = nullptr;  ///< null: nothing computed yet
  std::uint64_t contraction_bits = 0;
  double floor_Pa = 0;
  double ceiling_Pa = 0;
  bool ceiling_is_supply = true;
};

struct LimitsData {
  io::Command previous{};
  bool has_previous = false;
  std::array<std::uint32_t, io::kMaxJoints> flags{};  ///< flags of the last call, per joint
  std::array<std::uint64_t, 5> counts{};              ///< how often each flag fired, by bit index
  /// Per joint, agonist [0] and antagonist [1]: the last band (the joint set-ups must not change
  /// while a LimitsData is in use; they are immutable once built).
  std::array<std::array<PressureBandMemo, 2>, io::kMaxJoints> bands{};
  std::uint64_t band_evaluations = 0;  ///< bands computed (two pressure-model evaluations each), not reused
};

/// The pressure band of step 3 for muscle `m` of `joint` at rigid-wire contraction `eps`.
struct PressureBand {
  double floor_Pa = 0;    ///< keeps the pretension by the model (0 where the model cannot make it)
  double ceiling_Pa = 0;  ///< min(supply, the pressure at which the model makes the force ceiling)
  bool ceiling_is_supply = true;  ///< the supply is the ceiling (the model reaches the force ceiling only above it, or never)
};
PressureBand pressure_band(const models::MuscleModel& m, const models::JointModel& joint, double eps) noexcept;

/// Limits `command` in place against `state`. Returns the or of all joints' flags. `joints[j]` must
/// be set for every j < model.joint_count.
std::uint32_t apply_limits(const LimitsModel& model, const JointModels& joints, LimitsData& data, const io::SensorState& state,
                           io::Command& command) noexcept;

}  // namespace peha::safety
