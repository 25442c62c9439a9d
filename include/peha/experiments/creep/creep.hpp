#pragma once
/// \file
/// The wire-creep experiment (docs/creep.md, issue 14 part 2): a long E1-like run (the one-DOF rig
/// holding its payload while a finger pushes it up and down, over and over) on a plant whose wires
/// creep several times faster than the default, with the creep estimator off and on, for each
/// force-trim rate of the scenario (the default trim and the paper's pure feed-forward, 0) and each
/// plant variant. Figures: the estimate against the plant's true creep, the force-tracking error,
/// the static torque error after each release, the time of the recalibrate alert against the
/// instant the truth crossed the threshold. The scenario is E1's (configs/e1_creep.yaml) plus a
/// `creep:` section; `experiment: wire_creep`.

#include "peha/config/reader.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/robustness/robustness.hpp"
#include "peha/experiments/run_request.hpp"

#include <string>
#include <vector>

namespace peha::experiments {

/// What the creep verdict judges (the `creep.verdict:` section; these are the defaults).
struct CreepVerdictThresholds {
  double max_estimate_rms_m = 0.0005;   ///< RMS(estimate - truth) per wire after the convergence window, m
  double max_estimate_error_m = 0.001;  ///< max |estimate - truth| per wire after it, m
  /// The recalibrate alert latches at most this long after the truth crossed the threshold, s (a
  /// wire whose truth never crosses must not alert: an alert then fails the check).
  double max_alert_delay_s = 300.0;
  double max_early_alert_s = 0.0;       ///< an alert this long before the truth crossed is a false alarm, s
  /// With the estimator on, |static torque error| at each release of the last quarter, % of the
  /// plant's gravity torque (every trim rate).
  double max_static_torque_error_pct = 5.0;
  /// Pure feed-forward (trim 0): force-tracking RMS of the agonist, estimator on / off, over the
  /// last quarter of the run, at most this.
  double max_tracking_ratio = 0.8;
};

struct CreepSettings {
  double repeat_from_s = 6.0;   ///< the finger pushes starting at or after this repeat ...
  double cycle_s = 20.0;        ///< ... every cycle_s until the run ends, s
  double sample_s = 1.0;        ///< resolution of the time series, s
  double convergence_s = 120.0; ///< the estimate's errors are judged from this time on, s
  std::vector<double> force_trim_rates_1ps = {4.0, 0.0};  ///< one run pair (off, on) per rate
  std::vector<PlantVariant> variants;                      ///< plant variants (reported, nominal judged)
  CreepVerdictThresholds verdict;
  /// `calibration:` (optional): every run uses both muscles calibrated on the variant's plant (its
  /// wires not yet crept), as the robustness matrix's e1_calibrated_ff; without it, the scenario's
  /// (nominal) model. The estimator measures creep against the model (docs/creep.md).
  bool calibrate = false;
  int calibration_restarts = 30;
  int calibration_pseudo_inputs = 50;
  int calibration_spgp_iterations = 300;
};

struct CreepScenario {
  E1Scenario e1;          ///< the pushes already repeated over the run
  CreepSettings creep;
};

/// Reads a `wire_creep` scenario; throws config::Error on anything the schema does not accept.
CreepScenario read_creep(const config::Document& doc);

/// One instant of the time series (every sample_s).
struct CreepSample {
  double t_s = 0;
  double angle_deg = 0;
  double truth_m[2] = {0, 0};       ///< plant creep since the estimator's reference (absolute when it is off), m (agonist, antagonist)
  double estimate_m[2] = {0, 0};    ///< the estimator's length change, m (0 when off or before its reference)
  double sigma_m[2] = {0, 0};       ///< its standard deviation, m
  double tracking_rms_N[2] = {0, 0};  ///< RMS(force request - load cell) over the last sample_s, N
  double gated_fraction[2] = {0, 0};  ///< share of the last sample_s's steps the estimator accepted
  std::uint32_t alerts = 0;         ///< control::CreepAlert bits latched so far
};

struct CreepRelease {
  double time_s = 0;
  double angle_deg = 0;
  double static_torque_error_pct = 0;  ///< plant truth, as E1: the last second before the next push
};

struct CreepRun {
  std::string name;            ///< e.g. "nominal_trim4_on"
  std::string variant;
  double force_trim_rate_1ps = 0;
  bool estimator = false;
  std::vector<CreepSample> samples;
  std::vector<CreepRelease> releases;
  double reference_time_s[2] = {-1, -1};  ///< when the estimator fixed each wire's reference, s
  double truth_at_reference_m[2] = {0, 0};
  double estimate_rms_m[2] = {0, 0};      ///< after convergence_s (NaN when off)
  double estimate_max_m[2] = {0, 0};
  double alert_time_s[4] = {-1, -1, -1, -1};  ///< control::CreepAlert order
  double truth_cross_s[2] = {-1, -1};     ///< the truth's change crossed alert_m, s (< 0 never)
  double final_truth_m[2] = {0, 0};       ///< plant creep at the end (absolute), m
  double tracking_rms_last_quarter_N[2] = {0, 0};
  double static_error_last_quarter_max_pct = 0;  ///< max |static torque error| over the last quarter's releases
  double static_error_last_quarter_mean_pct = 0; ///< mean signed
  double min_wire_tension_N = 0;          ///< plant truth after the start-up
  double realtime_factor = 0;
  double simulated_s = 0;
  std::uint64_t faults = 0;    ///< faults the supervisor's plausibility stage latched
  std::string fault_reason;    ///< the first one
};

/// One run: the scenario's case `c`, plant variant `v`, force trim `trim_1ps`, estimator on (the
/// scenario's controller.creep_estimator with enabled set) or off. `controller` (optional) replaces
/// the scenario's controller model (a calibrated one); the payload is the case's either way.
CreepRun run_creep_case(const CreepScenario& s, const E1Case& c, const PlantVariant& v, double trim_1ps, bool estimator,
                        const control::OneDofControllerModel* controller = nullptr);

/// The scenario with both muscles recorded and calibrated on variant `v`'s plant with its wires'
/// creep switched off (a freshly calibrated rig), the start-up tare off (the calibration fixes the
/// load cells' zero). Throws config::Error without a calibration: section.
E1Scenario creep_calibrated_scenario(const CreepScenario& s, const PlantVariant& v);

/// The verdict over a set of runs (see CreepVerdictThresholds); the checks say which run they judge.
safety::Verdict creep_verdict(const CreepScenario& s, const std::vector<CreepRun>& runs);

}  // namespace peha::experiments
