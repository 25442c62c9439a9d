#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/io/backend.hpp"

#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/models/units.hpp"
#include "peha/safety/fault_monitor.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <stdexcept>

namespace peha::experiments {
namespace {

using io::kNaN;

/// Keeps the few log columns the matrix reads, one vector each (the run is short: a few thousand
/// rows): time and fault flags, and per joint (its columns named by a prefix: "" on E1, "sfe_", ...
/// on the arm) the plant's angle, both muscles' forces and both wires' tensions.
class Columns final : public runtime::RowSink {
 public:
  /// `joint_names[j]` names the joint whose columns start with `joint_prefixes[j]`.
  Columns(const std::vector<std::string>& names, const std::vector<std::string>& joint_prefixes, std::vector<std::string> joint_names)
      : joints_(joint_prefixes.size()), joint_names_(std::move(joint_names)) {
    if (joint_names_.size() != joints_) throw std::invalid_argument("fault matrix: one joint name per column prefix");
    std::vector<std::string> wanted = {"t_s", "fault_flags"};
    for (const std::string& j : joint_prefixes) {
      for (const char* c : {"plant_angle_rad", "plant_agonist_force_N", "plant_antagonist_force_N", "plant_agonist_tension_N",
                            "plant_antagonist_tension_N"}) {
        wanted.push_back(j + c);
      }
    }
    for (const std::string& want : wanted) {
      const auto it = std::find(names.begin(), names.end(), want);
      index_.push_back(it == names.end() ? -1 : static_cast<int>(it - names.begin()));
    }
    values_.resize(index_.size());
  }
  void push_row(std::span<const double> row) noexcept override {
    for (std::size_t i = 0; i < index_.size(); ++i) values_[i].push_back(index_[i] >= 0 ? row[static_cast<std::size_t>(index_[i])] : kNaN);
  }
  std::size_t joints() const { return joints_; }
  const std::string& joint_name(std::size_t j) const { return joint_names_[j]; }
  const std::vector<double>& t() const { return values_[0]; }
  const std::vector<double>& flags() const { return values_[1]; }
  const std::vector<double>& angle(std::size_t j) const { return values_[2 + 5 * j]; }
  const std::vector<double>& force(std::size_t j, int m) const { return values_[2 + 5 * j + 1 + static_cast<std::size_t>(m)]; }
  const std::vector<double>& tension(std::size_t j, int m) const { return values_[2 + 5 * j + 3 + static_cast<std::size_t>(m)]; }

 private:
  std::size_t joints_;
  std::vector<std::string> joint_names_;
  std::vector<int> index_;
  std::vector<std::vector<double>> values_;
};

std::string safe_state_of(const std::string& reason) {
  for (const char* s : {"descend", "vent", "hold"}) {
    if (reason.find(s) != std::string::npos) return s;
  }
  return "-";
}

/// What a run gave the row besides its log.
struct RunOutcome {
  double period_s = 1e-3;
  std::string fault_reason;
  const safety::Verdict* verdict = nullptr;
  bool passed = false;
  const std::vector<runtime::LifecycleEvent>* lifecycle = nullptr;  ///< the supervisor's transitions
  const safety::LimitsModel* limits = nullptr;  ///< the joints' ranges (io order) and the monitor's speed threshold
  double host_watchdog_s = 0.02;                ///< the lifecycle's silence before a fault
  double recovery_ramp_s = 1.0;                 ///< the lifecycle's ramp from the measured pressures after a recovery
};

/// The outage (state_loss, board_reboot) a row injects, or nullopt.
std::optional<sim::FaultKind> outage_of(const std::string& fault) {
  for (sim::FaultKind k : {sim::FaultKind::kStateLoss, sim::FaultKind::kBoardReboot}) {
    if (fault == sim::fault_kind_name(k)) return k;
  }
  return std::nullopt;
}

/// "backend silent for longer than ... (holding ...)" -> "backend silent".
std::string short_reason(const char* reason) {
  std::string s(reason);
  for (const char* cut : {" (", " for longer"}) s = s.substr(0, s.find(cut));
  return s;
}

FaultRow analyse(const RunOutcome& r, const Columns& log, const FaultRow& what, std::size_t expected_rows) {
  FaultRow row = what;
  row.log_complete = log.t().size() == expected_rows;
  row.passed = r.passed;
  const std::size_t n = log.t().size();
  // Rows by time: an outage's cycles have none (no sample, no row).
  auto row_at = [&](double t_s) {
    return static_cast<std::size_t>(std::lower_bound(log.t().begin(), log.t().end(), t_s - 0.5 * r.period_s) - log.t().begin());
  };
  const auto k0 = std::min(n ? n - 1 : 0, row_at(row.fault_time_s));
  std::size_t detected_at = n;
  for (std::size_t k = 0; k < n; ++k) {
    if (log.flags()[k] != 0 && std::isfinite(log.flags()[k])) {
      detected_at = k;
      break;
    }
  }
  row.detected = detected_at < n;
  const auto first_flag = row.detected ? static_cast<std::uint32_t>(log.flags()[detected_at]) : 0u;
  row.flag = row.detected ? safety::fault_flag_name(first_flag & (~first_flag + 1)) : "-";
  row.detection_cycles = row.detected ? std::round((log.t()[detected_at] - row.fault_time_s) / r.period_s) : kNaN;
  row.safe_state = row.detected ? safe_state_of(r.fault_reason) : "-";
  // An outage is the lifecycle's to detect (the host hears nothing: no flag, no row); the row is judged
  // from the samples after it, when the operator re-arms.
  const std::optional<sim::FaultKind> outage = outage_of(row.fault);
  std::size_t judged_from = std::max<std::size_t>(k0, 1);
  if (outage) {
    row.detected = false, row.flag = "-", row.detection_cycles = kNaN, row.safe_state = "-";
    for (const runtime::LifecycleEvent& e : *r.lifecycle) {
      if (e.t_s + 1e-9 < row.fault_time_s) continue;
      if (!row.detected && e.transition == runtime::Transition::kFault) {
        row.detected = true;
        row.flag = short_reason(e.reason);
        row.detection_cycles = std::round((e.t_s - row.fault_time_s) / r.period_s);
        // A silent link holds the last command; any other outage disarms (the board's vent).
        row.safe_state = std::string(e.reason).find("holding") != std::string::npos ? "hold" : "vent";
      }
      if (row.detected && e.transition == runtime::Transition::kRecovered && std::isnan(row.recovered_after_s)) {
        row.recovered_after_s = e.t_s - row.fault_time_s;
      }
    }
    // Prompt for an outage: within the host's watchdog, the designed silence before it faults.
    row.prompt_cycles = static_cast<int>(std::ceil(r.host_watchdog_s / r.period_s)) + 1;
    const double back_s = row.fault_time_s + sim::fault_default_value(*outage);
    judged_from = std::min(n, row_at(back_s) + 1);  // the first speed spans two samples after the outage
  }
  row.min_tension_N = std::numeric_limits<double>::infinity();
  row.rest_after_s = kNaN;
  // An outage's re-arm: the outputs follow the host again from here (a rebooted board is safe, venting,
  // until then); its wires are judged from the ramp's end, when the muscles have refilled - as the
  // start-up's are judged after its refill (before it they are slack on purpose: vented).
  std::size_t rearm_k = n, tension_from = judged_from;
  if (outage && !std::isnan(row.recovered_after_s)) {
    rearm_k = std::min(n, row_at(row.fault_time_s + row.recovered_after_s));
    tension_from = std::min(n, row_at(row.fault_time_s + row.recovered_after_s + r.recovery_ramp_s));
  }
  double rearmed_speed_degps = 0;  // the fastest joint from the re-arm on
  double quiet_s = 0;
  for (std::size_t k = judged_from; k < n; ++k) {
    double speed = 0;  // the fastest joint's
    const double dt_s = log.t()[k] - log.t()[k - 1];
    for (std::size_t j = 0; j < log.joints(); ++j) {
      const double joint_speed = models::rad_to_deg(std::abs(log.angle(j)[k] - log.angle(j)[k - 1]) / dt_s);
      speed = std::max(speed, joint_speed);
      if (joint_speed > row.peak_speed_degps) row.peak_speed_degps = joint_speed, row.peak_speed_joint = log.joint_name(j);
      if (k > rearm_k) rearmed_speed_degps = std::max(rearmed_speed_degps, joint_speed);
      const double force = std::max(log.force(j, 0)[k], log.force(j, 1)[k]);
      if (force > row.peak_force_N) row.peak_force_N = force, row.peak_force_joint = log.joint_name(j);
      const double tension = std::min(log.tension(j, 0)[k], log.tension(j, 1)[k]);
      if (k >= tension_from && tension < row.min_tension_N) row.min_tension_N = tension, row.min_tension_joint = log.joint_name(j);
    }
    if (row.detected && k >= detected_at && std::isnan(row.rest_after_s)) {
      quiet_s = speed < 5.0 ? quiet_s + r.period_s : 0.0;
      if (quiet_s >= 0.5) row.rest_after_s = std::max(0.0, static_cast<double>(k - detected_at) * r.period_s - 0.5);
    }
  }
  for (const safety::Check& c : r.verdict->checks) {
    const bool range = c.figure.ends_with("lowest angle") || c.figure.ends_with("highest angle");
    const bool envelope = c.figure.ends_with("peak force") || c.figure.ends_with("highest pressure") || c.figure.ends_with("peak motor torque") ||
                          (range && !outage);
    if (envelope && !c.passed()) ++row.limits_exceeded;
  }
  if (outage) {
    // Recovers without launching the joint: re-armed, never faster than the monitor's speed trip, and
    // never further out of the range than where the outage left the joint (a board that went safe
    // may have let it down onto its stop: physics, while nothing is armed).
    const double max_speed_degps = models::rad_to_deg(r.limits->monitor.max_joint_speed_radps);
    if (std::isnan(row.recovered_after_s)) ++row.limits_exceeded;
    if (row.peak_speed_degps > max_speed_degps) ++row.limits_exceeded;
    const std::size_t back = judged_from - 1;
    int rearmed_exceeded = rearmed_speed_degps > max_speed_degps;
    for (std::size_t j = 0; j < log.joints() && back < n; ++j) {
      const double lo = std::min(r.limits->joints[j].min_angle_rad, log.angle(j)[back]) - safety::kRangeTolerance_rad;
      const double hi = std::max(r.limits->joints[j].max_angle_rad, log.angle(j)[back]) + safety::kRangeTolerance_rad;
      const auto [low, high] = std::minmax_element(log.angle(j).begin() + static_cast<std::ptrdiff_t>(back), log.angle(j).end());
      row.limits_exceeded += (*low < lo) + (*high > hi);
      if (rearm_k < n) {  // from the re-arm on: never further out than where the joint lay then
        const double rearmed_lo = std::min(lo, log.angle(j)[rearm_k] - safety::kRangeTolerance_rad);
        const double rearmed_hi = std::max(hi, log.angle(j)[rearm_k] + safety::kRangeTolerance_rad);
        const auto [rlow, rhigh] = std::minmax_element(log.angle(j).begin() + static_cast<std::ptrdiff_t>(rearm_k), log.angle(j).end());
        rearmed_exceeded += (*rlow < rearmed_lo) + (*rhigh > rearmed_hi);
      }
    }
    // A rebooting board is off: its outputs safe, its muscles venting, nothing peha sends reaches them
    // until the operator re-arms it. What the limb does until then (a fall onto its stop, its swing)
    // is physics; a limit exceeded from the re-arm on is a miss.
    if (*outage == sim::FaultKind::kBoardReboot && row.limits_exceeded > 0 && rearm_k < n && rearmed_exceeded == 0) {
      row.physics_forbids = fmt::format("the board is off until the re-arm: its outputs vent the limb and nothing reaches them, so it falls "
                                        "while nothing is armed; from the re-arm on every joint within the limits ({:.1f} deg/s at most)",
                                        rearmed_speed_degps);
    }
  }
  return row;
}

/// Runs the nominal row and then every kind at every moment: `run_one(faults, row)` runs one and
/// returns its analysed row (`row` names the fault); `target(kind)` labels the row's target.
std::vector<FaultRow> matrix_rows(const std::string& experiment, const FaultMoment& nominal, const std::vector<FaultMoment>& moments,
                                  const FaultMatrixOptions& options, const safety::MonitorParams& monitor, int joint, const std::function<std::string(sim::FaultKind)>& target,
                                  const std::function<FaultRow(const std::vector<sim::PlantFault>&, const FaultRow&)>& run_one,
                                  const std::function<void(const FaultRow&)>& progress) {
  std::vector<sim::FaultKind> kinds = options.kinds;
  if (kinds.empty()) kinds.assign(sim::all_fault_kinds().begin(), sim::all_fault_kinds().end());
  auto named = [&](const std::string& fault, const std::string& tgt, const FaultMoment& m) {
    FaultRow row;
    row.experiment = experiment;
    row.fault = fault;
    row.target = tgt;
    row.moment = m.name;
    row.fault_time_s = m.time_s;
    return row;
  };
  // Prompt: within 5 cycles, or within the caught flag's own designed window when that is longer (a
  // stuck load cell needs loadcell_stuck_cycles equal readings: fewer happen by chance).
  auto judged = [&](FaultRow row) {
    if (outage_of(row.fault)) return row;  // analyse set the watchdog's window
    row.prompt_cycles = row.flag == safety::fault_flag_name(safety::kFaultLoadcellStuck) ? std::max(5, monitor.loadcell_stuck_cycles) : 5;
    return row;
  };
  std::vector<FaultRow> out;
  out.push_back(judged(run_one({}, named("none", "-", nominal))));
  if (progress) progress(out.back());
  // A fault of `kind` at `moment` on the matrix's joint, muscle faults on the agonist, which carries
  // the load (E1's payload, the arm's forearm).
  auto fault_at = [&](sim::FaultKind kind, const FaultMoment& moment) {
    sim::PlantFault f;
    f.kind = kind;
    f.time_s = moment.time_s;
    f.joint = joint;
    f.muscle = 0;
    f.value = sim::fault_default_value(kind);
    return f;
  };
  for (const FaultMoment& moment : moments) {
    for (sim::FaultKind kind : kinds) {
      FaultRow row = judged(run_one({fault_at(kind, moment)}, named(sim::fault_kind_name(kind), target(kind), moment)));
      if (row.limits_exceeded > 0 && row.physics_forbids.empty()) row.physics_forbids = physics_forbids(kind);
      if (progress) progress(row);
      out.push_back(std::move(row));
    }
    // Two faults at once, on the carrying muscle's joint: a pair runs when both its kinds are wanted.
    for (const auto& [a, b] : double_faults()) {
      if (std::find(kinds.begin(), kinds.end(), a) == kinds.end() || std::find(kinds.begin(), kinds.end(), b) == kinds.end()) continue;
      const std::string name = std::string(sim::fault_kind_name(a)) + "+" + sim::fault_kind_name(b);
      FaultRow row = judged(run_one({fault_at(a, moment), fault_at(b, moment)}, named(name, target(a), moment)));
      if (row.limits_exceeded > 0) {
        const std::string why_a = physics_forbids(a), why_b = physics_forbids(b);
        row.physics_forbids = why_a.empty() ? why_b : why_b.empty() ? why_a : why_a + "; " + why_b;
      }
      if (progress) progress(row);
      out.push_back(std::move(row));
    }
  }
  return out;
}

}  // namespace

const std::vector<std::pair<sim::FaultKind, sim::FaultKind>>& double_faults() {
  using K = sim::FaultKind;
  // A dead pressure sensor hides a stuck-open valve from the pressure checks (the load cell read
  // 2740-2783 N for seconds under descend); a stuck cell when the supply halves; a motor that dies
  // as the wire slips; a frozen encoder (no speed to govern with) while a cell drifts.
  static const std::vector<std::pair<K, K>> pairs = {{K::kPressureSensorFail, K::kValveStuckOpen},
                                                     {K::kLoadcellStuck, K::kSupplyHalf},
                                                     {K::kMotorFault, K::kWireSlip},
                                                     {K::kEncoderFrozen, K::kLoadcellDrift}};
  return pairs;
}

namespace {
/// An outage row's unattended operator: recovers recover_delay_s after the samples come back; other
/// rows stay in their fault (-1: only on request).
double recover_after_s(const FaultMatrixOptions& options, const std::string& fault) {
  const std::optional<sim::FaultKind> outage = outage_of(fault);
  return outage ? sim::fault_default_value(*outage) + options.recover_delay_s : -1.0;
}
/// The cycles an outage row has no sample in (hence no log row).
std::size_t outage_cycles(const std::string& fault, double period_s) {
  const std::optional<sim::FaultKind> outage = outage_of(fault);
  return outage ? static_cast<std::size_t>(std::llround(sim::fault_default_value(*outage) / period_s)) : 0;
}
}  // namespace

double row_after_fault_s(const FaultMatrixOptions& options, const std::string& fault) {
  if (const std::optional<sim::FaultKind> outage = outage_of(fault)) {
    return sim::fault_default_value(*outage) + options.recover_delay_s + options.after_fault_s;
  }
  // A pair is as slow as its fastest member: encoder_frozen+loadcell_drift is judged in the frozen
  // encoder's window, as its single row is.
  const bool slow = fault == sim::fault_kind_name(sim::FaultKind::kLoadcellDrift);
  return slow ? std::max(options.after_fault_s, options.slow_after_fault_s) : options.after_fault_s;
}

std::string physics_forbids(sim::FaultKind kind) {
  switch (kind) {
    case sim::FaultKind::kWireBreak:
      return "the broken wire carries 0 N whatever is commanded; the other muscle pulls the other way and the 2.5 Nm motor cannot hold the payload";
    case sim::FaultKind::kValveStuckOpen:
      return "the stuck valve fills the muscle toward supply; only the on/off dump valve empties it: kept, the force passes the ceiling; "
             "dumped, the link falls";
    case sim::FaultKind::kValveStuckClosed:
      return "the carrying muscle's valve is stuck on the air it had (less during a push, when the finger helps): the antagonist pulls "
             "down and the 2.5 Nm motor cannot make up the difference, so the link sinks to its stop";
    case sim::FaultKind::kEstop:
      return "the e-stop cuts valves and motor in hardware (stop category 0): no output is left to govern a descent";
    default: return {};
  }
}

std::vector<FaultMoment> e1_fault_moments(const E1Scenario& scenario) {
  std::vector<FaultMoment> m;
  // Start-up: in the vent and in the tare (the muscles vented on purpose, the limb on its support).
  const control::LoadcellCheck& tare = scenario.controller.allocation.loadcell_check;
  if (tare.tare_s > 0) {
    m.push_back({"startup_vent", 0.5 * tare.vent_s});
    m.push_back({"tare", tare.vent_s + 0.5 * tare.tare_s});
  }
  m.push_back({"holding", 4.0});
  const auto& pushes = scenario.plant.finger.pushes;
  if (pushes.size() > 1) {
    const auto& p = pushes[1];
    m.push_back({"push", p.start_s + 0.5 * p.move_s});
    m.push_back({"after_release", p.start_s + p.duration_s + 0.5});
  }
  return m;
}

std::vector<FaultMoment> select_fault_moments(std::vector<FaultMoment> all, const std::vector<std::string>& wanted, const char* experiment) {
  std::string names;
  for (const FaultMoment& m : all) names += (names.empty() ? "" : "|") + m.name;
  for (const std::string& w : wanted) {
    if (std::none_of(all.begin(), all.end(), [&](const FaultMoment& m) { return m.name == w; })) {
      throw std::invalid_argument(fmt::format("{} has no moment '{}' (it has {})", experiment, w, names));
    }
  }
  if (!wanted.empty()) {
    std::erase_if(all, [&](const FaultMoment& m) { return std::find(wanted.begin(), wanted.end(), m.name) == wanted.end(); });
  }
  return all;
}

std::vector<FaultRow> run_fault_matrix(E1Scenario s, const FaultMatrixOptions& options, const std::function<void(const FaultRow&)>& progress) {
  E1Case c = s.cases.front();
  if (!options.case_name.empty()) {
    const auto it = std::find_if(s.cases.begin(), s.cases.end(), [&](const E1Case& e) { return e.name == options.case_name; });
    if (it == s.cases.end()) throw std::invalid_argument(fmt::format("peha faults: no case named '{}'", options.case_name));
    c = *it;
  }
  const std::vector<FaultMoment> moments = select_fault_moments(e1_fault_moments(s), options.moments, "E1");
  const std::vector<std::string> names = e1_log_columns();
  auto run_one = [&](const std::vector<sim::PlantFault>& faults, const FaultRow& what) {
    E1Scenario run = s;
    run.duration_s = std::min(s.duration_s, what.fault_time_s + row_after_fault_s(options, what.fault));
    run.plant.faults = faults;
    run.lifecycle.recover_after_s = recover_after_s(options, what.fault);
    Columns log(names, {""}, sim::one_dof_rig_joint_names());
    const E1Result r = run_e1_case(run, c, &log);
    const auto rows = static_cast<std::size_t>(std::llround(run.duration_s / run.period_s)) + 1 - outage_cycles(what.fault, run.period_s);
    return analyse({run.period_s, r.fault_reason, &r.verdict, r.within_limits, &r.lifecycle, &run.limits, run.lifecycle.host_watchdog_s, run.lifecycle.recovery_ramp_s}, log, what, rows);
  };
  auto target = [](sim::FaultKind kind) { return std::string(sim::fault_targets_muscle(kind) ? "joint.agonist" : "joint"); };
  return matrix_rows("E1", {"nominal", 4.0}, moments, options, s.limits.monitor, 0, target, run_one, progress);
}

namespace {
/// The io index of kE3FaultJoint in `scenario` (the joint count when the arm has no such joint).
std::size_t e3_fault_joint(const ArmScenario& scenario) {
  const std::vector<std::string>& joints = arm_joint_names(scenario);
  return static_cast<std::size_t>(std::find(joints.begin(), joints.end(), kE3FaultJoint) - joints.begin());
}
}  // namespace

std::vector<FaultMoment> e3_fault_moments(const ArmScenario& scenario) {
  // The operator's script: "start" (the hold while compensation comes on), then one move per posture.
  const std::vector<sim::OperatorMove> moves = postures_plant_params(scenario).operator_hands.moves;
  if (moves.size() < 3) throw std::invalid_argument("peha faults: E3's rows need at least two postures (holding the first, moving to the second)");
  const sim::OperatorMove& first = moves[1];
  const sim::OperatorMove& second = moves[2];
  std::vector<FaultMoment> moments = {{"holding", first.start_s + first.duration_s + 1.0}, {"moving", second.start_s + 0.5 * second.move_s}};
  // The faulted joint (the elbow) on the operator's first move that flexes it by 45 deg or more:
  // `elbow_moving`, the middle of that move (the elbow itself turning: at `moving` the shoulder
  // moves and the elbow stays straight), and `elbow_flexed`, 1 s after its release (at the other
  // moments the elbow is straight, at its range's end, where a descent has no room to act).
  const std::size_t elbow = e3_fault_joint(scenario);
  for (std::size_t i = 1; i < moves.size(); ++i) {
    const sim::OperatorMove& m = moves[i];
    if (elbow < m.target_rad.size() && std::isfinite(m.target_rad[elbow]) && m.target_rad[elbow] >= models::deg_to_rad(45.0)) {
      moments.push_back({"elbow_moving", m.start_s + 0.5 * m.move_s});
      moments.push_back({"elbow_flexed", m.start_s + m.duration_s + 1.0});
      break;
    }
  }
  return moments;
}

std::vector<FaultRow> run_fault_matrix(ArmScenario s, const FaultMatrixOptions& options, const std::function<void(const FaultRow&)>& progress) {
  if (!options.case_name.empty()) throw std::invalid_argument(fmt::format("peha faults: E3 has no cases (found --case '{}')", options.case_name));
  s.faults.clear();  // the matrix injects its own
  const std::vector<std::string>& joints = arm_joint_names(s);
  const std::size_t elbow = e3_fault_joint(s);
  if (elbow == joints.size()) throw std::invalid_argument(fmt::format("peha faults: the arm has no joint {}", kE3FaultJoint));
  const std::vector<FaultMoment> all = e3_fault_moments(s);
  const std::vector<FaultMoment> moments = select_fault_moments(all, options.moments, "E3");
  double end_s = 0;  // the nominal run covers every faulted run's span
  for (const FaultMoment& m : moments) end_s = std::max(end_s, m.time_s + options.after_fault_s);
  std::vector<std::string> prefixes;  // arm_log_columns' joints, in io order
  for (std::size_t j = 0; j < s.plant.actuated.size(); ++j) prefixes.push_back(arm_log_prefix(s, j) + "_");
  auto run_one = [&](const std::vector<sim::PlantFault>& faults, const FaultRow& what) {
    ArmScenario run = s;
    const double after_s = row_after_fault_s(options, what.fault);
    run.postures_stop_s = faults.empty() ? std::max(end_s, what.fault_time_s + after_s) : what.fault_time_s + after_s;
    run.faults = faults;
    run.lifecycle.recover_after_s = recover_after_s(options, what.fault);
    Columns log(arm_log_columns(s), prefixes, joints);
    const PosturesResult r = run_postures(run, &log);
    const auto rows = static_cast<std::size_t>(std::llround(postures_duration_s(run) / run.period_s)) + 1 - outage_cycles(what.fault, run.period_s);
    return analyse({run.period_s, r.fault_reason, &r.verdict, r.within_limits, &r.lifecycle, &run.limits, run.lifecycle.host_watchdog_s, run.lifecycle.recovery_ramp_s}, log, what, rows);
  };
  const std::string joint = joints[elbow];
  auto target = [&joint](sim::FaultKind kind) {
    if (kind == sim::FaultKind::kSupplyZero || kind == sim::FaultKind::kSupplyHalf || kind == sim::FaultKind::kEstop) return std::string("arm");
    return sim::fault_targets_muscle(kind) ? joint + ".agonist" : joint;
  };
  return matrix_rows("E3", {"nominal", all.front().time_s}, moments, options, s.limits.monitor, static_cast<int>(elbow), target, run_one,
                     progress);
}

void write_fault_matrix(const std::filesystem::path& dir, const std::vector<FaultRow>& rows, const std::string& scenario_name,
                        double after_fault_s, double slow_after_fault_s) {
  auto num = [](double v, const char* f) { return std::isfinite(v) ? fmt::format(fmt::runtime(f), v) : std::string("-"); };
  std::ofstream csv(dir / "faults.csv");
  csv << "experiment,fault,target,moment,fault_time_s,detected,flag,detection_cycles,prompt_cycles,safe_state,rest_after_s,peak_force_N,peak_speed_degps,"
         "min_tension_N,limits_exceeded,physics_forbids,log_complete,verdict_passed,peak_force_joint,peak_speed_joint,min_tension_joint,"
         "recovered_after_s\n";
  for (const FaultRow& r : rows) {
    csv << fmt::format("{},{},{},{},{:.3f},{},{},{},{},{},{},{:.1f},{:.2f},{:.2f},{},\"{}\",{},{},{},{},{},{}\n", r.experiment, r.fault, r.target,
                       r.moment, r.fault_time_s, r.detected ? 1 : 0, r.flag, num(r.detection_cycles, "{:.0f}"), r.prompt_cycles, r.safe_state,
                       num(r.rest_after_s, "{:.3f}"), r.peak_force_N, r.peak_speed_degps, r.min_tension_N, r.limits_exceeded, r.physics_forbids,
                       r.log_complete ? 1 : 0, r.passed ? 1 : 0, r.peak_force_joint, r.peak_speed_joint, r.min_tension_joint,
                       num(r.recovered_after_s, "{:.3f}"));
  }
  std::size_t faults = 0, detected = 0, within5 = 0, clean = 0, complete = 0, forbidden = 0;
  for (const FaultRow& r : rows) {
    if (r.fault == "none") continue;
    ++faults;
    detected += r.detected;
    within5 += r.detected && r.detection_cycles <= r.prompt_cycles;
    clean += r.limits_exceeded == 0;
    forbidden += !r.physics_forbids.empty();
    complete += r.log_complete;
  }
  const std::string experiment = rows.empty() ? std::string("-") : rows.front().experiment;
  const std::string what =
      experiment == "E3"
          ? fmt::format("E3 (postures) on the arm scenario `{}`: faults on the elbow {} (muscle faults on its agonist; supply faults "
                        "and the e-stop hit every joint) at `holding` (1 s after the operator lets go of the first posture), `moving` "
                        "(the middle of the operator's move to the second), and, where a posture flexes the elbow by 45 deg or more, "
                        "`elbow_moving` (the middle of the move into the first such posture) and `elbow_flexed` (1 s after its "
                        "release). Force, speed and tension are the worst of the actuated "
                        "joints (each figure names its joint); the limits are every joint's",
                        scenario_name, kE3FaultJoint)
          : std::string("E1 on the one-DOF rig: muscle faults on the agonist, at `startup_vent` and `tare` (the start-up, the link on its pin), `holding` (4 s, at rest), `push` (the middle of the "
                        "first push's move) and `after_release` (0.5 s after it lets go)");
  std::ofstream md(dir / "faults.md");
  md << "# Fault matrix: " << experiment << "\n\n";
  md << fmt::format("Scenario `{}`, in process, the supervisor's plausibility stage on, the start-up tare as configured. {}. Each fault "
                    "starts at its moment and stays; the run ends {:g} s later ({:g} s for a drifting load cell alone). An outage "
                    "(`state_loss`, `board_reboot`) lasts its value and ends; the operator recovers 0.5 s after it, and its row is judged "
                    "from the samples after it: re-armed, no joint faster than the speed trip or further out of its range than it lay (a rebooting "
                    "board's fall before the re-arm is physics), its wires from the end of the re-arm's ramp.\n\n",
                    scenario_name, what, after_fault_s, std::max(after_fault_s, slow_after_fault_s));
  md << fmt::format("Faults injected: {}; detected: {}; promptly (within 5 control cycles, or a stuck load cell within its "
                    "loadcell_stuck_cycles window): {}; no limit exceeded: {}; a limit exceeded where physics "
                    "forbids any safe state to avoid it: {}; a limit exceeded otherwise (a miss of the designed outcome): {}; log complete: {}.\n\n",
                    faults, detected, within5, clean, forbidden, faults - clean - forbidden, complete);
  md << "| fault | target | moment | detected by | cycles | safe state | at rest after s | peak force N | peak speed deg/s | min tension N "
        "| limits exceeded | physics forbids | log complete |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  // On the arm each figure names the joint it comes from.
  auto at = [&](const std::string& joint) { return experiment == "E3" && !joint.empty() ? " " + joint : std::string(); };
  for (const FaultRow& r : rows) {
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {:.0f}{} | {:.1f}{} | {:.1f}{} | {} | {} | {} |\n", r.fault, r.target, r.moment,
                      r.detected ? r.flag : "**not detected**", num(r.detection_cycles, "{:.0f}"), r.safe_state, num(r.rest_after_s, "{:.2f}"),
                      r.peak_force_N, at(r.peak_force_joint), r.peak_speed_degps, at(r.peak_speed_joint), r.min_tension_N,
                      at(r.min_tension_joint), r.limits_exceeded, r.physics_forbids.empty() ? "-" : r.physics_forbids,
                      r.log_complete ? "yes" : "**no**");
  }
}

}  // namespace peha::experiments
