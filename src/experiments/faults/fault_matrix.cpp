#include "peha/experiments/faults/fault_matrix.hpp"

#include "peha/safety/fault_monitor.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

namespace peha::experiments {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = std::numbers::pi / 180.0;

/// Keeps the few log columns the matrix reads, one vector each (the run is short: a few thousand rows).
class Columns final : public runtime::RowSink {
 public:
  explicit Columns(const std::vector<std::string>& names) {
    for (const char* want : {"t_s", "plant_angle_rad", "plant_agonist_force_N", "plant_antagonist_force_N", "plant_agonist_tension_N",
                             "plant_antagonist_tension_N", "fault_flags"}) {
      const auto it = std::find(names.begin(), names.end(), want);
      index_.push_back(it == names.end() ? -1 : static_cast<int>(it - names.begin()));
    }
    values_.resize(index_.size());
  }
  void push_row(std::span<const double> row) noexcept override {
    for (std::size_t i = 0; i < index_.size(); ++i) values_[i].push_back(index_[i] >= 0 ? row[static_cast<std::size_t>(index_[i])] : kNaN);
  }
  const std::vector<double>& t() const { return values_[0]; }
  const std::vector<double>& angle() const { return values_[1]; }
  const std::vector<double>& force(int m) const { return values_[static_cast<std::size_t>(2 + m)]; }
  const std::vector<double>& tension(int m) const { return values_[static_cast<std::size_t>(4 + m)]; }
  const std::vector<double>& flags() const { return values_[6]; }

 private:
  std::vector<int> index_;
  std::vector<std::vector<double>> values_;
};

std::string safe_state_of(const std::string& reason) {
  for (const char* s : {"descend", "vent", "hold"}) {
    if (reason.find(s) != std::string::npos) return s;
  }
  return "-";
}

FaultRow analyse(const E1Scenario& s, const E1Result& r, const Columns& log, const std::string& fault, const std::string& target,
                 const FaultMoment& moment, std::size_t expected_rows) {
  FaultRow row;
  row.fault = fault;
  row.target = target;
  row.moment = moment.name;
  row.fault_time_s = moment.time_s;
  row.log_complete = log.t().size() == expected_rows;
  row.passed = r.within_limits;
  const std::size_t n = log.t().size();
  const auto k0 = std::min(n ? n - 1 : 0, static_cast<std::size_t>(std::llround(moment.time_s / s.period_s)));
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
  row.detection_cycles = row.detected ? static_cast<double>(detected_at) - static_cast<double>(k0) : kNaN;
  row.safe_state = row.detected ? safe_state_of(r.fault_reason) : "-";
  row.min_tension_N = std::numeric_limits<double>::infinity();
  row.rest_after_s = kNaN;
  double quiet_s = 0;
  for (std::size_t k = std::max<std::size_t>(k0, 1); k < n; ++k) {
    const double speed = std::abs(log.angle()[k] - log.angle()[k - 1]) / s.period_s / kDeg;
    row.peak_speed_degps = std::max(row.peak_speed_degps, speed);
    row.peak_force_N = std::max({row.peak_force_N, log.force(0)[k], log.force(1)[k]});
    row.min_tension_N = std::min({row.min_tension_N, log.tension(0)[k], log.tension(1)[k]});
    if (row.detected && k >= detected_at && std::isnan(row.rest_after_s)) {
      quiet_s = speed < 5.0 ? quiet_s + s.period_s : 0.0;
      if (quiet_s >= 0.5) row.rest_after_s = std::max(0.0, static_cast<double>(k - detected_at) * s.period_s - 0.5);
    }
  }
  for (const safety::Check& c : r.verdict.checks) {
    const bool envelope = c.figure.ends_with("peak force") || c.figure.ends_with("highest pressure") || c.figure.ends_with("peak motor torque") ||
                          c.figure.ends_with("lowest angle") || c.figure.ends_with("highest angle");
    if (envelope && !c.passed()) ++row.limits_exceeded;
  }
  return row;
}

}  // namespace

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
  std::vector<FaultMoment> m = {{"holding", 4.0}};
  const auto& pushes = scenario.plant.finger.pushes;
  if (pushes.size() > 1) {
    const auto& p = pushes[1];
    m.push_back({"push", p.start_s + 0.5 * p.move_s});
    m.push_back({"after_release", p.start_s + p.duration_s + 0.5});
  }
  return m;
}

std::vector<FaultRow> run_fault_matrix(E1Scenario s, const FaultMatrixOptions& options, const std::function<void(const FaultRow&)>& progress) {
  s.limits.monitor.enabled = true;
  E1Case c = s.cases.front();
  if (!options.case_name.empty()) {
    const auto it = std::find_if(s.cases.begin(), s.cases.end(), [&](const E1Case& e) { return e.name == options.case_name; });
    if (it == s.cases.end()) throw std::invalid_argument(fmt::format("peha faults: no case named '{}'", options.case_name));
    c = *it;
  }
  std::vector<FaultMoment> moments = e1_fault_moments(s);
  if (!options.moments.empty()) {
    std::erase_if(moments, [&](const FaultMoment& m) { return std::find(options.moments.begin(), options.moments.end(), m.name) == options.moments.end(); });
  }
  std::vector<sim::FaultKind> kinds = options.kinds;
  if (kinds.empty()) kinds.assign(sim::all_fault_kinds().begin(), sim::all_fault_kinds().end());
  const std::vector<std::string> names = e1_log_columns();

  auto run_one = [&](const std::vector<sim::PlantFault>& faults, const FaultMoment& moment, const std::string& fault, const std::string& target) {
    E1Scenario run = s;
    run.duration_s = std::min(s.duration_s, moment.time_s + options.after_fault_s);
    run.plant.faults = faults;
    Columns log(names);
    const E1Result r = run_e1_case(run, c, &log);
    const auto rows = static_cast<std::size_t>(std::llround(run.duration_s / run.period_s)) + 1;
    FaultRow row = analyse(run, r, log, fault, target, moment, rows);
    if (progress) progress(row);
    return row;
  };

  std::vector<FaultRow> out;
  out.push_back(run_one({}, {"nominal", 4.0}, "none", "-"));
  for (const FaultMoment& moment : moments) {
    for (sim::FaultKind kind : kinds) {
      sim::PlantFault f;
      f.kind = kind;
      f.time_s = moment.time_s;
      f.joint = 0;
      f.muscle = 0;  // muscle faults on the agonist, which carries the payload
      f.value = sim::fault_default_value(kind);
      const std::string target = sim::fault_targets_muscle(kind) ? "joint.agonist" : "joint";
      FaultRow row = run_one({f}, moment, sim::fault_kind_name(kind), target);
      if (row.limits_exceeded > 0) row.physics_forbids = physics_forbids(kind);
      out.push_back(std::move(row));
    }
  }
  return out;
}

void write_fault_matrix(const std::filesystem::path& dir, const std::vector<FaultRow>& rows, const std::string& scenario_name) {
  auto num = [](double v, const char* f) { return std::isfinite(v) ? fmt::format(fmt::runtime(f), v) : std::string("-"); };
  std::ofstream csv(dir / "faults.csv");
  csv << "fault,target,moment,fault_time_s,detected,flag,detection_cycles,safe_state,rest_after_s,peak_force_N,peak_speed_degps,"
         "min_tension_N,limits_exceeded,physics_forbids,log_complete,verdict_passed\n";
  for (const FaultRow& r : rows) {
    csv << fmt::format("{},{},{},{:.3f},{},{},{},{},{},{:.1f},{:.2f},{:.2f},{},\"{}\",{},{}\n", r.fault, r.target, r.moment, r.fault_time_s,
                       r.detected ? 1 : 0, r.flag, num(r.detection_cycles, "{:.0f}"), r.safe_state, num(r.rest_after_s, "{:.3f}"),
                       r.peak_force_N, r.peak_speed_degps, r.min_tension_N, r.limits_exceeded, r.physics_forbids, r.log_complete ? 1 : 0,
                       r.passed ? 1 : 0);
  }
  std::size_t faults = 0, detected = 0, within5 = 0, clean = 0, complete = 0, forbidden = 0;
  for (const FaultRow& r : rows) {
    if (r.fault == "none") continue;
    ++faults;
    detected += r.detected;
    within5 += r.detected && r.detection_cycles <= 5;
    clean += r.limits_exceeded == 0;
    forbidden += !r.physics_forbids.empty();
    complete += r.log_complete;
  }
  std::ofstream md(dir / "faults.md");
  md << "# Fault matrix\n\n";
  md << fmt::format("Scenario `{}`, in process, the supervisor's plausibility stage on, the start-up tare as configured. Each fault "
                    "starts at its moment and stays; the run ends 5 s later.\n\n", scenario_name);
  md << fmt::format("Faults injected: {}; detected: {}; within 5 control cycles: {}; no limit exceeded: {}; a limit exceeded where physics "
                    "forbids any safe state to avoid it: {}; a limit exceeded otherwise (a miss of the designed outcome): {}; log complete: {}.\n\n",
                    faults, detected, within5, clean, forbidden, faults - clean - forbidden, complete);
  md << "| fault | target | moment | detected by | cycles | safe state | at rest after s | peak force N | peak speed deg/s | min tension N "
        "| limits exceeded | physics forbids | log complete |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const FaultRow& r : rows) {
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {:.0f} | {:.1f} | {:.1f} | {} | {} | {} |\n", r.fault, r.target, r.moment,
                      r.detected ? r.flag : "**not detected**", num(r.detection_cycles, "{:.0f}"), r.safe_state, num(r.rest_after_s, "{:.2f}"),
                      r.peak_force_N, r.peak_speed_degps, r.min_tension_N, r.limits_exceeded, r.physics_forbids.empty() ? "-" : r.physics_forbids,
                      r.log_complete ? "yes" : "**no**");
  }
}

}  // namespace peha::experiments
