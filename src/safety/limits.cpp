#include "peha/safety/limits.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace peha::safety {
namespace {

/// The band of muscle `m` of `joint` at `eps`, from `memo` when it holds the band of the same joint
/// set-up at the same contraction (bit for bit), else computed and kept there.
PressureBand memoized_band(const models::MuscleModel& m, const models::JointModel& joint, double eps, PressureBandMemo& memo,
                           std::uint64_t& evaluations) noexcept {
  const auto bits = std::bit_cast<std::uint64_t>(eps);
  if (memo.joint != &joint || memo.contraction_bits != bits) {
    const PressureBand b = pressure_band(m, joint, eps);
    memo = {&joint, bits, b.floor_Pa, b.ceiling_Pa, b.ceiling_is_supply};
    ++evaluations;
  }
  return {memo.floor_Pa, memo.ceiling_Pa, memo.ceiling_is_supply};
}

double step_toward(double previous, double wanted, double max_step, bool& limited) {
  const double next = std::clamp(wanted, previous - max_step, previous + max_step);
  limited = limited || next != wanted;
  return next;
}

}  // namespace

PressureBand pressure_band(const models::MuscleModel& m, const models::JointModel& joint, double eps) noexcept {
  const double force_ceiling = models::force_ceiling_N(m);
  // The ceiling is the pressure at which the model makes exactly the force ceiling. When the model
  // cannot reach it at all (kUnreachable/kSaturated), the supply is the ceiling.
  // Both ends at the same contraction: the residual is evaluated for both in one pass.
  models::InverseResult ends[2];
  models::muscle_pressure_pair(m, force_ceiling, joint.pretension_N, eps, joint.supply_pressure_Pa, ends);
  const models::InverseResult& top = ends[0];
  PressureBand band{0.0, joint.supply_pressure_Pa, true};
  if (top.status == models::InverseStatus::kOk && top.pressure_Pa < joint.supply_pressure_Pa) {
    band.ceiling_Pa = top.pressure_Pa;
    band.ceiling_is_supply = false;
  }
  // The floor keeps the pretension; where the model says the muscle cannot make it (unreachable),
  // forcing the supply would be the wrong guess, so there is no floor.
  const models::InverseResult& bottom = ends[1];
  band.floor_Pa = bottom.status == models::InverseStatus::kOk ? std::min(bottom.pressure_Pa, band.ceiling_Pa) : 0.0;
  return band;
}

std::uint32_t apply_limits(const LimitsModel& model, const JointModels& joints, LimitsData& data, const io::SensorState& state,
                           io::Command& command) noexcept {
  std::uint32_t all = 0;
  command.joint_count = model.joint_count;
  for (int j = 0; j < model.joint_count; ++j) {
    const JointLimits& lim = model.joints[j];
    const models::JointModel& jm = *joints[static_cast<std::size_t>(j)];
    const io::JointSensors& s = state.joints[j];
    io::JointCommand& c = command.joints[j];
    const io::JointCommand prev = data.has_previous ? data.previous.joints[j] : io::JointCommand{};
    std::uint32_t flags = 0;

    if (!std::isfinite(c.agonist_pressure_Pa)) c.agonist_pressure_Pa = prev.agonist_pressure_Pa, flags |= kNonFinite;
    if (!std::isfinite(c.antagonist_pressure_Pa)) c.antagonist_pressure_Pa = prev.antagonist_pressure_Pa, flags |= kNonFinite;
    if (!std::isfinite(c.motor_torque_Nm)) c.motor_torque_Nm = 0.0, flags |= kNonFinite;

    const double angle = std::isfinite(s.angle_rad) ? s.angle_rad : 0.0;
    if (angle > lim.max_angle_rad) {
      if (c.agonist_pressure_Pa > prev.agonist_pressure_Pa) c.agonist_pressure_Pa = prev.agonist_pressure_Pa;
      c.motor_torque_Nm = std::min(c.motor_torque_Nm, 0.0);
      flags |= kJointRange;
    } else if (angle < lim.min_angle_rad) {
      if (c.antagonist_pressure_Pa > prev.antagonist_pressure_Pa) c.antagonist_pressure_Pa = prev.antagonist_pressure_Pa;
      c.motor_torque_Nm = std::max(c.motor_torque_Nm, 0.0);
      flags |= kJointRange;
    }

    const double r0 = jm.pulley_radius_m;
    auto& memo = data.bands[static_cast<std::size_t>(j)];
    const PressureBand b1 = memoized_band(jm.agonist, jm, models::rigid_contraction(jm.agonist, r0, +1, angle), memo[0],
                                          data.band_evaluations);
    const PressureBand b2 = memoized_band(jm.antagonist, jm, models::rigid_contraction(jm.antagonist, r0, -1, angle), memo[1],
                                          data.band_evaluations);
    const double p1 = std::clamp(c.agonist_pressure_Pa, b1.floor_Pa, b1.ceiling_Pa);
    const double p2 = std::clamp(c.antagonist_pressure_Pa, b2.floor_Pa, b2.ceiling_Pa);
    if (p1 != c.agonist_pressure_Pa || p2 != c.antagonist_pressure_Pa) flags |= kPressureLimited;
    c.agonist_pressure_Pa = p1;
    c.antagonist_pressure_Pa = p2;

    if (data.has_previous) {
      bool limited = false;
      const double dp = lim.pressure_rate_Pa_per_s * model.period_s;
      // A falling ceiling (the model's force cap) must win over the rate limit.
      c.agonist_pressure_Pa = std::min(step_toward(prev.agonist_pressure_Pa, c.agonist_pressure_Pa, dp, limited), b1.ceiling_Pa);
      c.antagonist_pressure_Pa = std::min(step_toward(prev.antagonist_pressure_Pa, c.antagonist_pressure_Pa, dp, limited), b2.ceiling_Pa);
      c.motor_torque_Nm = step_toward(prev.motor_torque_Nm, c.motor_torque_Nm, lim.motor_rate_Nm_per_s * model.period_s, limited);
      if (limited) flags |= kRateLimited;
    }

    const double motor_max = jm.has_motor ? jm.motor_max_torque_Nm : 0.0;
    const double tau = std::clamp(c.motor_torque_Nm, -motor_max, motor_max);
    if (tau != c.motor_torque_Nm) flags |= kMotorLimited;
    c.motor_torque_Nm = tau;

    data.flags[j] = flags;
    for (std::uint32_t f = flags; f != 0; f &= f - 1) ++data.counts[std::countr_zero(f)];
    all |= flags;
  }
  io::copy_used(data.previous, command);
  data.has_previous = true;
  return all;
}

}  // namespace peha::safety
