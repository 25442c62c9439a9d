#include "peha/control/wire_creep_estimator.hpp"

#include "peha/models/units.hpp"

#include <algorithm>
#include <cmath>

namespace peha::control {

CreepEstimatorParams read_creep_estimator(config::Map map) {
  CreepEstimatorParams p;
  p.enabled = map.boolean_or("enabled", p.enabled);
  p.correct = map.boolean_or("correct", p.correct);
  p.process_noise_m_per_sqrt_s = map.number_or("process_noise_mm_per_sqrt_s", p.process_noise_m_per_sqrt_s * 1e3, {0.0, 10.0}) * 1e-3;
  p.block_s = map.number_or("block_s", p.block_s, {1e-3, 10.0});
  p.reference_delay_s = map.number_or("reference_delay_s", p.reference_delay_s, {0.0, 3600.0});
  p.reference_s = map.number_or("reference_s", p.reference_s, {0.0, 600.0});
  p.force_bin_N = map.number_or("force_bin_N", p.force_bin_N, {1.0, 5000.0});
  p.residual_at_corrected_contraction = map.boolean_or("residual_at_corrected_contraction", p.residual_at_corrected_contraction);
  p.model_force_fraction = map.number_or("model_force_fraction", p.model_force_fraction, {1e-4, 1.0});
  p.loadcell_noise_N = map.number_or("loadcell_noise_N", p.loadcell_noise_N, {0.0, 1000.0});
  p.pressure_noise_Pa = map.number_or("pressure_noise_MPa", p.pressure_noise_Pa * 1e-6, {0.0, 0.1}) * 1e6;
  p.min_pressure_Pa = map.number_or("min_pressure_MPa", p.min_pressure_Pa * 1e-6, {0.0, 1.0}) * 1e6;
  p.min_force_N = map.number_or("min_force_N", p.min_force_N, {0.1, 5000.0});
  p.max_speed_radps = models::deg_to_rad(map.number_or("max_speed_degps", models::rad_to_deg(p.max_speed_radps), {0.0, 1000.0}));
  p.settle_tolerance_Pa = map.number_or("settle_tolerance_MPa", p.settle_tolerance_Pa * 1e-6, {0.0, 1.0}) * 1e6;
  p.max_correction_m = map.number_or("max_correction_mm", p.max_correction_m * 1e3, {0.0, 50.0}) * 1e-3;
  p.alert_m = map.number_or("alert_mm", p.alert_m * 1e3, {0.0, 50.0}) * 1e-3;
  p.alert_sigmas = map.number_or("alert_sigmas", p.alert_sigmas, {0.0, 10.0});
  p.alert_scale_fraction = map.number_or("alert_scale_fraction", p.alert_scale_fraction, {0.0, 1.0});
  p.slack_force_N = map.number_or("slack_force_N", p.slack_force_N, {0.0, 1000.0});
  p.slack_model_force_N = map.number_or("slack_model_force_N", p.slack_model_force_N, {0.0, 5000.0});
  p.slack_s = map.number_or("slack_s", p.slack_s, {0.0, 60.0});
  if (p.slack_model_force_N < p.slack_force_N) {
    map.fail("slack_model_force_N", "must be at least slack_force_N (the model must expect more than a slack wire carries)");
  }
  map.finish();
  return p;
}

const char* creep_alert_name(CreepAlert bit) noexcept {
  switch (bit) {
    case kCreepRecalibrateAgonist: return "creep_recalibrate agonist";
    case kCreepRecalibrateAntagonist: return "creep_recalibrate antagonist";
    case kWireSlackAgonist: return "wire_slack agonist";
    case kWireSlackAntagonist: return "wire_slack antagonist";
  }
  return "";
}

int creep_bin(double angle_rad, double force_N, double force_bin_N) noexcept {
  if (!std::isfinite(angle_rad) || !std::isfinite(force_N) || !(force_bin_N > 0.0)) return -1;
  const double a = (angle_rad - kCreepAngleBinLow_rad) / kCreepAngleBinWidth_rad;
  if (!(a >= 0.0) || !(a < kCreepAngleBins)) return -1;
  const double f = std::max(force_N, 0.0) / force_bin_N;
  const int fi = f >= kCreepForceBins - 1 ? kCreepForceBins - 1 : static_cast<int>(f);
  return static_cast<int>(a) * kCreepForceBins + fi;
}

CreepMeasurement measure_wire_offset(const models::MuscleModel& m, double pulley_radius_m, int side, double angle_rad,
                                     double pressure_Pa, double force_N, const CreepEstimatorParams& p,
                                     double residual_offset_m) noexcept {
  CreepMeasurement out;
  if (!std::isfinite(angle_rad) || !std::isfinite(pressure_Pa) || !std::isfinite(force_N)) return out;
  if (!(pressure_Pa > 0.0) || !(force_N > 0.0)) return out;
  const models::TendonSpringParams& pam = m.pam;
  const double eps = models::rigid_contraction(m, pulley_radius_m, side, angle_rad);
  // The learned residual is a pressure correction of the inverse (p* = g^-1(F) + f(eps, F)): the
  // parametric model's pressure is the measured one minus it. By default the caller evaluates it at
  // the rigid contraction (residual_offset_m = 0): at one operating point it is then a constant the
  // reference absorbs, the creep is read through the parametric model's slope, and the measurement
  // never depends on the estimate (no loop inside the estimator). At the corrected contraction the
  // SPGP's own slope in eps enters instead (CreepEstimatorParams::residual_at_corrected_contraction).
  double p_param = pressure_Pa;
  if (m.residual) {
    const double r = m.residual->pressure_Pa(eps + residual_offset_m / m.rest_length_m, force_N);
    if (std::isfinite(r)) p_param -= r;
  }
  if (!(p_param > 0.0)) return out;
  // g(u) = F / P on the decreasing branch of g: a u^2 + b u + (c - F/P) = 0,
  // u = 2 c' / (-b + sqrt(b^2 - 4 a c')) (the root where g'(u) = 2 a u + b < 0, stable for a -> 0).
  const double a = pam.a_N_per_Pa, b = pam.b_N_per_Pa;
  const double gain = force_N / p_param;
  const double c1 = pam.c_N_per_Pa - gain;
  const double disc = b * b - 4.0 * a * c1;
  if (!(disc >= 0.0)) return out;  // F/P below g's vertex value: no contraction makes it
  const double den = -b + std::sqrt(disc);
  if (!(den > 0.0)) return out;
  const double u = 2.0 * c1 / den;
  const double slope = 2.0 * a * u + b;  // g'(u), N/Pa per unit contraction (< 0)
  if (!(slope < 0.0) || !std::isfinite(u)) return out;
  const double L0 = m.rest_length_m;
  out.offset_m = (u - eps - pam.eps0 - force_N / pam.k_N) * L0;
  // Uncertainty: a relative error e of the gain g = F/P moves u by e g / |g'(u)|. The model's
  // relative uncertainty is systematic; the sensors' noise (relative in F and in P) is per sample.
  const double per_relative_m = gain / -slope * L0;
  const double relF = p.loadcell_noise_N / force_N, relP = p.pressure_noise_Pa / pressure_Pa;
  out.variance_m2 = per_relative_m * per_relative_m * p.model_force_fraction * p.model_force_fraction;
  out.noise_variance_m2 = per_relative_m * per_relative_m * (relF * relF + relP * relP);
  out.valid = std::isfinite(out.offset_m) && std::isfinite(out.variance_m2) && std::isfinite(out.noise_variance_m2);
  return out;
}

namespace {

void update_muscle(const models::JointModel& joint, const models::MuscleModel& m, int side, const CreepEstimatorParams& p,
                   const CreepEstimatorInput& in, int i, double tension_time_s, CreepMuscleState& s) noexcept {
  const double dt = in.dt_s;
  // The gate: static, settled, trusted.
  const double P = in.pressure_Pa[i], F = in.loadcell_N[i];
  bool accept = in.tension_expected && in.loadcell_ok[i] && std::isfinite(in.velocity_radps) &&
                std::abs(in.velocity_radps) <= p.max_speed_radps && P >= p.min_pressure_Pa && F >= p.min_force_N &&
                std::isfinite(in.previous_pressure_cmd_Pa[i]) &&
                std::abs(in.previous_pressure_cmd_Pa[i] - P) <= p.settle_tolerance_Pa;
  CreepMeasurement z;
  const int bin = accept ? creep_bin(in.angle_rad, F, p.force_bin_N) : -1;
  accept = accept && bin >= 0 && (s.block_bin < 0 || s.block_bin == bin);  // one operating point per block
  if (accept) {
    const double residual_offset_m = p.residual_at_corrected_contraction && s.referenced ? s.length_change_m : 0.0;
    z = measure_wire_offset(m, joint.pulley_radius_m, side, in.angle_rad, P, F, p, residual_offset_m);
    accept = z.valid;
  }
  s.gated = accept;
  if (accept) {
    s.block_bin = bin;
    s.block_sum_m += z.offset_m;
    s.block_var_sum_m2 += z.variance_m2;
    s.block_noise_sum_m2 += z.noise_variance_m2;
    ++s.block_samples;
  } else {
    // A block takes only static, settled samples: a rejected sample rejects the whole block, so
    // that a block's mean never mixes a move's transient into a hold.
    s.block_rejected = true;
  }
  s.block_time_s += dt;
  s.since_update_s += dt;
  if (s.block_time_s + 1e-12 < p.block_s) return;
  const bool full = !s.block_rejected && s.block_samples > 0;
  const double n = static_cast<double>(std::max<long>(s.block_samples, 1));
  const double mean_m = s.block_sum_m / n;
  // The model's part is systematic (it stays in the block's mean); the sensors' averages out.
  const double var_m2 = s.block_var_sum_m2 / n + s.block_noise_sum_m2 / (n * n);
  s.block_time_s = 0;
  s.block_sum_m = 0;
  s.block_var_sum_m2 = 0;
  s.block_noise_sum_m2 = 0;
  s.block_samples = 0;
  s.block_rejected = false;
  const int block_bin = s.block_bin;
  s.block_bin = -1;
  if (!full) return;
  s.last_offset_m = mean_m;
  if (tension_time_s < p.reference_delay_s) return;  // the start-up transient is nobody's reference
  // An operating point not learned yet learns its reference: relative to the estimate now (0 for
  // the first one). Its blocks do not update the estimate meanwhile.
  CreepBin& b = s.bins[block_bin];
  if (!b.learned) {
    b.sum_m += mean_m;
    ++b.blocks;
    if (!s.referenced) s.reference_var_sum_m2 += var_m2;
    if (static_cast<double>(b.blocks) * p.block_s + 1e-9 >= p.reference_s) {
      b.reference_m = b.sum_m / static_cast<double>(b.blocks) - s.length_change_m;
      b.learned = true;
      if (!s.referenced) {
        s.referenced = true;
        s.reference_m = b.reference_m;
        s.length_change_m = 0.0;
        // The first reference's own uncertainty starts the change's: systematic, so it does not
        // shrink with the number of blocks.
        s.variance_m2 = s.reference_var_sum_m2 / static_cast<double>(b.blocks);
      }
    }
    return;
  }
  // Kalman filter, random walk: predict over the time since the last update (the wire creeps
  // while the link moves too), then correct.
  const double q = p.process_noise_m_per_sqrt_s * p.process_noise_m_per_sqrt_s;
  s.variance_m2 += q * (s.referenced && s.updates > 0 ? s.since_update_s : p.block_s);
  s.since_update_s = 0;
  const double innovation = (mean_m - b.reference_m) - s.length_change_m;
  const double gain = s.variance_m2 / (s.variance_m2 + var_m2);
  s.length_change_m += p.gain_scale * gain * innovation;
  s.variance_m2 *= (1.0 - gain);
  ++s.updates;
}

}  // namespace

void update_creep_estimator(const models::JointModel& joint, const CreepEstimatorParams& p, CreepEstimatorData& d,
                            const CreepEstimatorInput& in) noexcept {
  if (!p.enabled) return;
  if (!(std::isfinite(in.dt_s) && in.dt_s > 0.0)) return;
  d.tension_time_s = in.tension_expected ? d.tension_time_s + in.dt_s : 0.0;
  const models::MuscleModel* muscles[2] = {&joint.agonist, &joint.antagonist};
  for (int i = 0; i < 2; ++i) {
    const int side = i == 0 ? +1 : -1;
    CreepMuscleState& s = d.muscle[i];
    update_muscle(joint, *muscles[i], side, p, in, i, d.tension_time_s, s);

    // creep_recalibrate: the change is past the threshold with n_sigma confidence.
    const std::uint32_t creep_bit = i == 0 ? kCreepRecalibrateAgonist : kCreepRecalibrateAntagonist;
    const double scale_m = p.alert_scale_fraction * s.length_change_m;
    if (s.referenced && !(d.alerts & creep_bit) &&
        std::abs(s.length_change_m) - p.alert_sigmas * std::sqrt(s.variance_m2 + scale_m * scale_m) > p.alert_m) {
      d.alerts |= creep_bit;
      d.alert_time_s[i] = in.time_s;
    }
    // wire_slack: the load cell reads (almost) nothing while the model, at the measured pressure and
    // the corrected contraction, expects a pull.
    const std::uint32_t slack_bit = i == 0 ? kWireSlackAgonist : kWireSlackAntagonist;
    const double P = in.pressure_Pa[i], F = in.loadcell_N[i];
    bool slack = false;
    if (in.tension_expected && std::isfinite(P) && std::isfinite(F) && std::isfinite(in.angle_rad) && F < p.slack_force_N) {
      const models::MuscleModel& m = *muscles[i];
      const double eps = models::rigid_contraction(m, joint.pulley_radius_m, side, in.angle_rad) +
                         creep_correction_m(p, d, i) / m.rest_length_m;
      slack = models::forward_force_N(m.pam, P, eps) > p.slack_model_force_N;
    }
    s.slack_time_s = slack ? s.slack_time_s + in.dt_s : 0.0;
    if (slack && s.slack_time_s >= p.slack_s && !(d.alerts & slack_bit)) {
      d.alerts |= slack_bit;
      d.alert_time_s[2 + i] = in.time_s;
    }
  }
}

double creep_correction_m(const CreepEstimatorParams& p, const CreepEstimatorData& d, int i) noexcept {
  if (!p.enabled || !p.correct || !d.muscle[i].referenced) return 0.0;
  return std::clamp(d.muscle[i].length_change_m, -p.max_correction_m, p.max_correction_m);
}

}  // namespace peha::control
