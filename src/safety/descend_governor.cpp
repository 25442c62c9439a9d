#include "peha/safety/descend_governor.hpp"

#include <algorithm>
#include <cmath>

namespace peha::safety {
namespace {

/// The carrying muscle is the one whose force (by the pressure model, at the pressures held) wins:
/// it holds the load, so the joint descends when it relaxes. It starts from what it held.
void start_descent(const DescendGovernorModel& model, const models::JointModel& joint, const io::JointCommand& held,
                   const double (&eps)[2], int outside, DescendGovernorData& g) noexcept {
  const double held_Pa[2] = {held.agonist_pressure_Pa, held.antagonist_pressure_Pa};
  const models::MuscleModel* mm[2] = {&joint.agonist, &joint.antagonist};
  double held_N[2];
  for (int m = 0; m < 2; ++m) held_N[m] = models::forward_force_N(mm[m]->pam, std::max(0.0, held_Pa[m]), eps[m]);
  // A joint found beyond an end of its range (on a stop after an outage, both muscles vented: their
  // forces say nothing) is carried by the muscle that pulls it back inside.
  g.carrying = outside < 0 ? 0 : outside > 0 ? 1 : held_N[0] >= held_N[1] ? 0 : 1;
  g.force_N = held_N[g.carrying];
  g.other_force_N = std::max(joint.pretension_N, held_N[1 - g.carrying]);
  g.ceiling_N = models::force_ceiling_N(*mm[g.carrying]);
  g.floor_N = std::min(g.ceiling_N, std::max(joint.pretension_N, model.floor_fraction * g.force_N));
  g.command_N = g.force_N;
  g.lagged_N[static_cast<std::size_t>(g.carrying)] = g.force_N;
  g.lagged_N[static_cast<std::size_t>(1 - g.carrying)] = g.other_force_N;
  g.trim_N = {};
  // A joint that starts inside its range was held there by this force (a fault while holding or
  // moving); one on a stop (after an outage) was not: its balance is not known yet.
  g.balance_N = outside == 0 ? g.force_N : 0.0;
  g.started = true;
}

/// The carrying muscle's force this period: a PI law on how much faster than wanted the joint descends.
double carrying_force_N(const DescendGovernorModel& model, const DescentSample& sample, DescendGovernorData& g) noexcept {
  // Descending = toward the range's end the carrying muscle lets go to (the agonist lifts toward +).
  const double down = g.carrying == 0 ? -1.0 : +1.0;
  const double room_rad = g.carrying == 0 ? sample.angle_rad - (sample.min_angle_rad + model.stop_margin_rad)
                                          : (sample.max_angle_rad - model.stop_margin_rad) - sample.angle_rad;
  // Slows to a stop stop_margin inside the end; beyond that point (a joint found on its stop after
  // an outage) the wanted motion reverses: back inside its range at up to the same speed.
  const double taper = std::clamp(room_rad / (2.0 * model.stop_margin_rad), -1.0, 1.0);
  const double wanted_radps = down * model.speed_radps * taper;
  // > 0: descending faster than wanted (more force); < 0: slower or held (bleed).
  const double excess_radps = down * (sample.speed_radps - wanted_radps);
  // Integral: bleeds at most force_rate while the joint is held, gains while too fast, kept while
  // someone lifts the joint (DescendGovernorModel::lift_speed_radps).
  const double ki = model.force_rate_N_per_s / model.speed_radps;
  const double up_radps = -down * sample.speed_radps;
  const double wanted_up_radps = std::max(0.0, -down * wanted_radps);
  const bool rising = up_radps > wanted_up_radps + model.lift_speed_radps;
  // Rising, the joint is lifted by an operator only if the carrying muscle pulls no harder than it
  // did while the joint was held still: then something else supplies the lift, and the force is kept
  // (bled, the elbow's flexor fell to 1.0-2.5 N under an operator flexing it). Pulling harder, the
  // muscle itself lifts the joint (speed alone cannot tell): bled, and pushed back in proportion.
  const bool operator_lifts = rising && g.command_N <= g.balance_N * (1.0 + model.balance_margin);
  const bool muscle_lifts = rising && !operator_lifts;
  // Held, or descending about as wanted, inside the range (a fall being caught is neither).
  if (std::abs(sample.speed_radps) <= 2.0 * model.speed_radps && room_rad > 0.0) g.balance_N = g.command_N;
  if (operator_lifts) g.lifted = true;
  if (down * sample.speed_radps >= 0.5 * model.speed_radps) g.lifted = false;  // descending on its own
  const double bleed = g.lifted ? model.lifted_bleed_fraction : 1.0;
  const double integrand = operator_lifts ? 0.0 : excess_radps < 0.0 ? bleed * std::max(excess_radps, -model.speed_radps) : excess_radps;
  g.force_N = std::clamp(g.force_N + ki * integrand * model.period_s, g.floor_N, g.ceiling_N);
  const double push_back_N = muscle_lifts ? model.gain_N_per_radps * (up_radps - wanted_up_radps - model.lift_speed_radps) : 0.0;
  // Proportional on a fall only (lowering slower than wanted is bled by the integral, never pushed
  // down); on the way back in from a stop both ways: the breakaway from the stop's friction otherwise
  // overshot to 33 deg/s.
  const double proportional_radps = wanted_up_radps > 0.0 ? excess_radps : std::max(0.0, excess_radps);
  const double wanted_N = std::clamp(g.force_N + model.gain_N_per_radps * proportional_radps - push_back_N, 0.0, g.ceiling_N);
  g.command_N = std::min(wanted_N, g.command_N + model.force_slew_N_per_s * model.period_s);
  return g.command_N;
}

}  // namespace

void govern_descent(const DescendGovernorModel& model, const models::JointModel& joint, const io::JointCommand& held,
                    const DescentSample& sample, DescendGovernorData& g) noexcept {
  const models::MuscleModel* mm[2] = {&joint.agonist, &joint.antagonist};
  double eps[2];
  for (int m = 0; m < 2; ++m) eps[m] = models::rigid_contraction(*mm[m], joint.pulley_radius_m, m == 0 ? +1 : -1, sample.angle_rad);
  if (!g.started) {
    const int outside = sample.angle_rad < sample.min_angle_rad ? -1 : sample.angle_rad > sample.max_angle_rad ? 1 : 0;
    start_descent(model, joint, held, eps, outside, g);
  }
  const auto c = static_cast<std::size_t>(g.carrying);
  const auto o = 1 - c;
  std::array<double, 2> force_N{};
  force_N[c] = carrying_force_N(model, sample, g);
  // The other muscle keeps the force it held: its wire stays taut.
  force_N[o] = g.other_force_N;
  const double lag = model.period_s / std::max(model.trim_lag_s, model.period_s);
  for (std::size_t m = 0; m < 2; ++m) {
    const double ceiling_N = models::force_ceiling_N(*mm[m]);
    g.lagged_N[m] += lag * (force_N[m] - g.lagged_N[m]);
    if (model.trim_rate_per_s > 0.0 && std::isfinite(sample.measured_N[m])) {
      g.trim_N[m] = std::clamp(g.trim_N[m] + model.trim_rate_per_s * (g.lagged_N[m] - sample.measured_N[m]) * model.period_s, -ceiling_N, ceiling_N);
    }
    const double wanted_N = std::clamp(force_N[m] + g.trim_N[m], 0.0, ceiling_N);
    g.pressure_Pa[m] = models::muscle_pressure(*mm[m], wanted_N, eps[m], joint.supply_pressure_Pa).pressure_Pa;
  }
  const double motor_max = joint.has_motor ? joint.motor_max_torque_Nm : 0.0;
  g.motor_Nm = std::clamp(-model.damping_Nms_per_rad * sample.speed_radps, -motor_max, motor_max);
}

}  // namespace peha::safety
