#include "peha/experiments/creep/creep.hpp"
#include "peha/io/backend.hpp"

#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>

namespace peha::experiments {
namespace {

using io::kNaN;

CreepSettings read_creep_section(config::Map m, double duration_s) {
  CreepSettings c;
  c.repeat_from_s = m.number("repeat_from_s", {0.0, duration_s});
  c.cycle_s = m.number("cycle_s", {1.0, 3600.0});
  c.sample_s = m.number_or("sample_s", c.sample_s, {0.01, 60.0});
  c.convergence_s = m.number_or("convergence_s", c.convergence_s, {0.0, duration_s});
  if (m.has("force_trim_rates_1ps")) {
    c.force_trim_rates_1ps = m.numbers("force_trim_rates_1ps", {0.0, 100.0}, 1, 4);
  }
  if (m.has("variants")) {
    for (config::Map v : m.maps("variants", 1, 16)) c.variants.push_back(read_plant_variant(v));
  } else {
    c.variants.push_back(PlantVariant{.name = "nominal"});
  }
  if (m.has("calibration")) {
    config::Map k = m.map("calibration");
    c.calibrate = true;
    c.calibration_restarts = static_cast<int>(k.integer("restarts", 1, 10000));
    c.calibration_pseudo_inputs = static_cast<int>(k.integer("pseudo_inputs", 1, 1000));
    c.calibration_spgp_iterations = static_cast<int>(k.integer("spgp_iterations", 0, 100000));
    k.finish();
  }
  if (m.has("verdict")) {
    config::Map v = m.map("verdict");
    CreepVerdictThresholds& t = c.verdict;
    t.max_estimate_rms_m = v.number_or("max_estimate_rms_mm", t.max_estimate_rms_m * 1e3, {0.0, 100.0}) * 1e-3;
    t.max_estimate_error_m = v.number_or("max_estimate_error_mm", t.max_estimate_error_m * 1e3, {0.0, 100.0}) * 1e-3;
    t.max_alert_delay_s = v.number_or("max_alert_delay_s", t.max_alert_delay_s, {0.0, 36000.0});
    t.max_early_alert_s = v.number_or("max_early_alert_s", t.max_early_alert_s, {0.0, 36000.0});
    t.max_static_torque_error_pct = v.number_or("max_static_torque_error_pct", t.max_static_torque_error_pct, {0.0, 1000.0});
    t.max_tracking_ratio = v.number_or("max_tracking_ratio", t.max_tracking_ratio, {0.0, 100.0});
    v.finish();
  }
  m.finish();
  return c;
}

/// The pushes from repeat_from_s on, repeated every cycle_s while they end within the run.
void repeat_pushes(E1Scenario& e1, const CreepSettings& c) {
  const std::vector<sim::FingerPush> once = e1.plant.finger.pushes;
  const std::vector<int> probes = e1.probe_direction;
  std::vector<sim::FingerPush> all;
  std::vector<int> directions;
  for (std::size_t i = 0; i < once.size(); ++i) {
    if (once[i].start_s < c.repeat_from_s) {
      all.push_back(once[i]);
      directions.push_back(probes[i]);
    }
  }
  for (int n = 0;; ++n) {
    bool any = false;
    for (std::size_t i = 0; i < once.size(); ++i) {
      if (once[i].start_s < c.repeat_from_s) continue;
      sim::FingerPush p = once[i];
      p.start_s += n * c.cycle_s;
      if (p.start_s + p.duration_s > e1.duration_s) continue;
      p.name = fmt::format("{}_{}", once[i].name, n);
      all.push_back(p);
      directions.push_back(probes[i]);
      any = true;
    }
    if (!any) break;
  }
  e1.plant.finger.pushes = all;
  e1.probe_direction = directions;
}

}  // namespace

CreepScenario read_creep(const config::Document& doc) {
  CreepScenario s;
  s.e1 = read_e1(doc, "wire_creep", [&s](config::Map& root) { s.creep = read_creep_section(root.map("creep"), 3600.0); });
  if (s.creep.convergence_s >= s.e1.duration_s) {
    throw config::Error(fmt::format("{}: creep.convergence_s ({} s) must end before the run (run.duration_s {} s)", doc.name(),
                                    s.creep.convergence_s, s.e1.duration_s));
  }
  repeat_pushes(s.e1, s.creep);
  return s;
}

E1Scenario creep_calibrated_scenario(const CreepScenario& cs, const PlantVariant& v) {
  E1Scenario s = cs.e1;
  for (int i = 0; i < 2; ++i) {
    if (!s.excitation[i]) {
      throw config::Error(fmt::format("creep.calibration needs the scenario's calibration.{} section (the excitation to record)",
                                      i == 0 ? "agonist" : "antagonist"));
    }
    E1Case recording{"calibration", s.excitation[i]->payload_kg};
    sim::OneDofRigParams plant = e1_variant_plant(cs.e1, recording, v);
    plant.joint.agonist.cable.creep_m_per_N_s = plant.joint.antagonist.cable.creep_m_per_N_s = 0.0;  // a fresh rig
    const calibration::Dataset data = record_e1_muscle(cs.e1, plant, i);
    calibration::CalibrateOptions o;
    o.muscle = i == 0 ? "agonist" : "antagonist";
    o.fit.restarts = cs.creep.calibration_restarts;
    o.fit.threads = 2;
    o.fit.seed = cs.e1.seed;
    o.spgp.num_pseudo = cs.creep.calibration_pseudo_inputs;
    o.spgp.max_iterations = cs.creep.calibration_spgp_iterations;
    o.spgp.seed = cs.e1.seed;
    o.use_spgp = cs.creep.calibration_spgp_iterations > 0;
    const calibration::CalibrationOutcome outcome = calibration::calibrate(data, o);
    const safety::JointLimits& range = s.limits.joints[0];
    calibration::apply_calibration(outcome.calibration, fmt::format("calibration of {} on variant {}", o.muscle, v.name), o.use_spgp,
                                   s.controller.joint, i, range.min_angle_rad, range.max_angle_rad);
  }
  use_calibration_loadcell_zero(s);
  return s;
}

namespace {

/// One creep run: the controller's update as its per-cycle step; as its per-cycle observation the
/// angle and constraint torque (for the releases), and the force-tracking error and gating gathered
/// into a CreepSample every sample_s. Every buffer, the samples' too, is sized before the loop: step,
/// hold and observe allocate nothing.
struct CreepCaseRun {
  CreepCaseRun(const CreepScenario& s, const E1Scenario& sc, const sim::OneDofRigBackend& plant,
               control::OneDofGravityController& controller, const PlantVariant& v, double trim_1ps, bool estimator, std::size_t steps)
      : plant(plant),
        controller(controller),
        estimator(estimator),
        per_sample(std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(s.creep.sample_s / sc.period_s)))),
        angle(steps + 1, 0.0),
        constraint(steps + 1, kNaN) {
    r.variant = v.name;
    r.force_trim_rate_1ps = trim_1ps;
    r.estimator = estimator;
    r.name = fmt::format("{}_trim{:g}_{}", v.name, trim_1ps, estimator ? "on" : "off");
    r.min_wire_tension_N = std::numeric_limits<double>::infinity();
    r.samples.reserve((steps + 1) / per_sample);  // at most one per per_sample observed cycles
  }

  void step(const io::SensorState& state, io::Command& command) { controller.update(state, command); }
  void hold(std::size_t k) { angle[k] = k > 0 ? angle[k - 1] : 0.0; }

  void observe(std::size_t k, const io::SensorState& state) {
    const sim::OneDofRigTruth& t = plant.sampled_truth();
    const io::JointSensors& sens = state.joints[0];
    const control::OneDofDiagnostics& d = controller.diagnostics();
    angle[k] = t.angle_rad;
    constraint[k] = t.constraint_torque_Nm;
    if (!controller.wires_slack_on_purpose(state.time_s)) {
      r.min_wire_tension_N = std::min({r.min_wire_tension_N, t.pulley_tension_min_N[0], t.pulley_tension_min_N[1]});
    }
    const double e0 = d.allocation.agonist_force_cmd_N - (sens.agonist_loadcell_N - d.loadcell_offset_N[0]);
    const double e1 = d.allocation.antagonist_force_cmd_N - (sens.antagonist_loadcell_N - d.loadcell_offset_N[1]);
    tracking_sum_N2[0] += e0 * e0;
    tracking_sum_N2[1] += e1 * e1;
    for (int i = 0; i < 2; ++i) {
      gated[i] += d.creep.muscle[i].gated ? 1.0 : 0.0;
      if (estimator && !referenced[i] && d.creep.muscle[i].referenced) {
        referenced[i] = true;
        r.reference_time_s[i] = state.time_s;
        r.truth_at_reference_m[i] = t.creep_m[i];
      }
    }
    if (++in_sample == per_sample) close_sample(state.time_s, t, d);
    for (int i = 0; i < 2; ++i) r.final_truth_m[i] = t.creep_m[i];
  }

  const sim::OneDofRigBackend& plant;
  control::OneDofGravityController& controller;
  const bool estimator;
  const std::size_t per_sample;                ///< observed cycles per CreepSample
  std::vector<double> angle, constraint;       ///< per cycle, plant truth: rad, Nm
  double tracking_sum_N2[2] = {0, 0}, gated[2] = {0, 0};  ///< over the sample so far
  std::size_t in_sample = 0;
  bool referenced[2] = {false, false};         ///< the estimator has taken its reference
  CreepRun r;                                  ///< the samples and the running figures

 private:
  /// The sample's means into a CreepSample; the sums start again.
  void close_sample(double t_s, const sim::OneDofRigTruth& t, const control::OneDofDiagnostics& d) {
    CreepSample smp;
    smp.t_s = t_s;
    smp.angle_deg = models::rad_to_deg(t.angle_rad);
    for (int i = 0; i < 2; ++i) {
      smp.truth_m[i] = t.creep_m[i] - r.truth_at_reference_m[i];
      smp.estimate_m[i] = d.creep.muscle[i].referenced ? d.creep.muscle[i].length_change_m : 0.0;
      smp.sigma_m[i] = control::creep_sigma_m(d.creep, i);
      smp.tracking_rms_N[i] = std::sqrt(tracking_sum_N2[i] / static_cast<double>(in_sample));
      smp.gated_fraction[i] = gated[i] / static_cast<double>(in_sample);
      tracking_sum_N2[i] = gated[i] = 0;
    }
    smp.alerts = d.creep.alerts;
    r.samples.push_back(smp);
    in_sample = 0;
  }
};

/// The estimate against the truth (change since the reference) after the convergence window, and
/// when the truth crossed the alert threshold.
void estimate_figures(const CreepScenario& s, const E1Scenario& sc, const CreepCaseRun& run, CreepRun& r) {
  const double alert_m = sc.controller.creep.alert_m;
  for (int i = 0; i < 2; ++i) {
    double sum = 0, worst = 0;
    std::size_t n = 0;
    for (const CreepSample& smp : r.samples) {
      if (r.truth_cross_s[i] < 0 && run.referenced[i] && std::abs(smp.truth_m[i]) > alert_m) r.truth_cross_s[i] = smp.t_s;
      if (!run.estimator || smp.t_s < s.creep.convergence_s) continue;
      const double e = smp.estimate_m[i] - smp.truth_m[i];
      sum += e * e;
      worst = std::max(worst, std::abs(e));
      ++n;
    }
    r.estimate_rms_m[i] = run.estimator && n ? std::sqrt(sum / static_cast<double>(n)) : kNaN;
    r.estimate_max_m[i] = run.estimator && n ? worst : kNaN;
  }
}

/// Force tracking over the last quarter of the run.
void tracking_figures(CreepRun& r) {
  const double quarter_s = 0.75 * r.simulated_s;
  for (int i = 0; i < 2; ++i) {
    double sum = 0;
    std::size_t n = 0;
    for (const CreepSample& smp : r.samples) {
      if (smp.t_s < quarter_s) continue;
      sum += smp.tracking_rms_N[i] * smp.tracking_rms_N[i];
      ++n;
    }
    r.tracking_rms_last_quarter_N[i] = n ? std::sqrt(sum / static_cast<double>(n)) : kNaN;
  }
}

/// Static torque error after each release: the friction's torque over the last second before the
/// next push (or the run's end), as E1 measures it, % of the plant's gravity torque there; the last
/// quarter's worst and mean.
void release_figures(const E1Scenario& sc, const sim::OneDofRigParams& plant_params, const CreepCaseRun& run, std::size_t done,
                     CreepRun& r) {
  const double quarter_s = 0.75 * r.simulated_s;
  const auto& pushes = sc.plant.finger.pushes;
  const auto span = static_cast<std::size_t>(std::llround(1.0 / sc.period_s));
  double worst = 0, sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    if (pushes[i].hold || sc.probe_direction[i] != 0) continue;
    const auto k0 = static_cast<std::size_t>(std::llround((pushes[i].start_s + pushes[i].duration_s) / sc.period_s));
    std::size_t k1 = done;
    if (i + 1 < pushes.size()) k1 = std::min(done, static_cast<std::size_t>(std::llround(pushes[i + 1].start_s / sc.period_s)) - 1);
    if (k0 >= done || k1 <= k0 + span) continue;
    double torque = 0;
    for (std::size_t k = k1 - span; k <= k1; ++k) torque += run.constraint[k];
    torque = -torque / static_cast<double>(span + 1);
    CreepRelease rel;
    rel.time_s = static_cast<double>(k0) * sc.period_s;
    rel.angle_deg = models::rad_to_deg(run.angle[k1]);
    rel.static_torque_error_pct = 100.0 * torque / std::abs(e1_plant_gravity_torque_Nm(plant_params, run.angle[k1]));
    r.releases.push_back(rel);
    if (rel.time_s >= quarter_s) {
      worst = std::max(worst, std::abs(rel.static_torque_error_pct));
      sum += rel.static_torque_error_pct;
      ++n;
    }
  }
  r.static_error_last_quarter_max_pct = n ? worst : kNaN;
  r.static_error_last_quarter_mean_pct = n ? sum / static_cast<double>(n) : kNaN;
}

}  // namespace

CreepRun run_creep_case(const CreepScenario& s, const E1Case& c, const PlantVariant& v, double trim_1ps, bool estimator,
                        const control::OneDofControllerModel* controller_model) {
  E1Scenario sc = s.e1;
  if (controller_model) sc.controller = *controller_model;
  sc.controller.allocation.force_trim_rate_1ps = trim_1ps;
  sc.controller.creep.enabled = estimator;
  const control::OneDofControllerModel model = e1_controller_model(sc, c);
  const sim::OneDofRigParams plant_params = e1_variant_plant(sc, c, v);
  sim::OneDofRigBackend plant(plant_params);
  control::OneDofGravityController controller(model);
  const safety::JointModels joints{&model.joint};
  safety::LimitedBackend limited(plant, sc.limits, joints);

  const auto steps = static_cast<std::size_t>(std::llround(sc.duration_s / sc.period_s));
  CreepCaseRun run(s, sc, plant, controller, v, trim_1ps, estimator, steps);
  io::SensorState state;
  io::Command command;
  const auto wall_start = std::chrono::steady_clock::now();
  const std::size_t done = runtime::run_cycles(
      limited, runtime::resuming(runtime::with_lifecycle({}, sc.lifecycle), [&controller] { controller.resume(); }), steps, state, command, [&](std::size_t) { run.step(state, command); },
      [&](std::size_t k) { run.hold(k); }, [&](std::size_t k, const io::Command&, std::uint32_t) { run.observe(k, state); });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  CreepRun r = std::move(run.r);  // the samples; the figures follow
  r.simulated_s = static_cast<double>(done) * sc.period_s;
  r.realtime_factor = r.simulated_s / std::max(wall_s, 1e-9);
  r.faults = limited.monitor().count();
  r.fault_reason = limited.monitor().run_reason();
  const control::CreepEstimatorData& cd = controller.diagnostics().creep;
  for (int i = 0; i < 4; ++i) r.alert_time_s[i] = cd.alert_time_s[i];
  estimate_figures(s, sc, run, r);
  tracking_figures(r);
  release_figures(sc, plant_params, run, done, r);
  return r;
}

safety::Verdict creep_verdict(const CreepScenario& s, const std::vector<CreepRun>& runs) {
  safety::Verdict v;
  const CreepVerdictThresholds& t = s.creep.verdict;
  const std::string nominal = s.creep.variants.front().name;
  const char* muscle[2] = {"agonist", "antagonist"};
  for (const CreepRun& r : runs) {
    if (r.variant != nominal) continue;  // variants are reported, not judged (docs/creep.md)
    v.at_most(r.name + " supervisor faults", "", static_cast<double>(r.faults), 0.0);
    if (r.estimator) {
      for (int i = 0; i < 2; ++i) {
        v.at_most(fmt::format("{} {} creep estimate RMS error", r.name, muscle[i]), "mm", r.estimate_rms_m[i] * 1e3,
                  t.max_estimate_rms_m * 1e3);
        v.at_most(fmt::format("{} {} creep estimate max error", r.name, muscle[i]), "mm", r.estimate_max_m[i] * 1e3,
                  t.max_estimate_error_m * 1e3);
        const double alert = r.alert_time_s[i], cross = r.truth_cross_s[i];
        if (cross >= 0) {
          // Not latched: late once the run went on max_alert_delay_s past the crossing; a run that
          // ended earlier is judged by how long it did go on (not late yet).
          const double delay = alert >= 0                                  ? alert - cross
                               : r.simulated_s - cross < t.max_alert_delay_s ? r.simulated_s - cross
                                                                              : std::numeric_limits<double>::infinity();
          v.within(fmt::format("{} {} creep_recalibrate alert after the truth crossed", r.name, muscle[i]), "s", delay,
                   -t.max_early_alert_s, t.max_alert_delay_s);
        } else {
          v.at_most(fmt::format("{} {} creep_recalibrate alert without the truth crossing (1 = raised)", r.name, muscle[i]), "",
                    alert >= 0 ? 1.0 : 0.0, 0.0);
        }
      }
      v.at_most(r.name + " |static torque error|, last quarter, max", "% of gravity", r.static_error_last_quarter_max_pct,
                t.max_static_torque_error_pct);
      v.at_most(r.name + " wire_slack alerts (no wire went slack)", "", ((r.alert_time_s[2] >= 0) + (r.alert_time_s[3] >= 0)) * 1.0, 0.0);
    }
  }
  // Pure feed-forward: the estimator's correction must cut the agonist's force-tracking error.
  for (const CreepRun& on : runs) {
    if (on.variant != nominal || !on.estimator || on.force_trim_rate_1ps != 0.0) continue;
    for (const CreepRun& off : runs) {
      if (off.variant != nominal || off.estimator || off.force_trim_rate_1ps != 0.0) continue;
      v.at_most(on.name + " agonist force-tracking RMS on / off, last quarter", "",
                on.tracking_rms_last_quarter_N[0] / std::max(off.tracking_rms_last_quarter_N[0], 1e-9), t.max_tracking_ratio);
    }
  }
  return v;
}

}  // namespace peha::experiments
