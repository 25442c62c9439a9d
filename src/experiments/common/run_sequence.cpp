// The one run sequence of every experiment (experiment.hpp), and the emulator's shared helpers.
#include "peha/experiments/common/experiment.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>

namespace peha::experiments {
namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

/// Names the sidecars (`<csv>.meta.json`: case, config, seed, column units, rows) the run wrote
/// beside its CSVs, under the line that lists the files: every experiment's, whatever it wrote.
void print_sidecars(const std::filesystem::path& dir) {
  std::size_t count = 0;
  std::string first;
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec); !ec && it != std::filesystem::recursive_directory_iterator();
       it.increment(ec)) {
    const std::string name = std::filesystem::relative(it->path(), dir, ec).string();
    if (!name.ends_with(".csv.meta.json")) continue;
    ++count;
    if (first.empty() || name < first) first = name;
  }
  if (count == 0) return;
  fmt::print("  and {} <csv>.meta.json beside the CSVs (case, config, seed, column units, rows), e.g. {}\n", count, first);
}

/// The indices of the cases --case selects (all when none is given); empty after a message.
std::vector<std::size_t> select_cases(const config::Document& doc, const std::vector<std::string>& names, const std::string& only) {
  std::vector<std::size_t> selected;
  if (names.empty()) {
    // --case on a one-run experiment is refused by the CLI (Takes::cases): one run, index 0.
    selected.push_back(0);
    return selected;
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (only.empty() || names[i] == only) selected.push_back(i);
  }
  if (selected.empty()) fmt::print(stderr, "error: no case named '{}' in {}; its cases: {}\n", only, doc.name(), joined(names));
  return selected;
}

}  // namespace

std::size_t failed_figures(const safety::Verdict& verdict) {
  std::size_t failed = 0;
  for (const auto& c : verdict.checks) failed += !c.passed();
  return failed;
}

void finish_telemetry(runtime::TelemetryTee& tee) {
  runtime::LogTelemetry* t = tee.telemetry();
  if (!t) return;
  t->close();
  const runtime::Telemetry& s = t->telemetry();
  fmt::print("  telemetry: {} signal(s), {} samples ({} dropped), {} datagrams -> udp://{}\n", t->selection().names.size(),
             s.published_samples(), s.dropped_samples(), s.sent_datagrams(), t->destination().to_string());
}

void finish_in_process_case(const RunContext& ctx, const hardware::Hardware& hw, const runtime::CsvLog& log, runtime::TelemetryTee& tee,
                            const char* prefix,
                            const std::string& case_name, const std::vector<std::string>& comments, double simulated_s,
                            double realtime_factor) {
  const std::filesystem::path log_path = ctx.dir / fmt::format("{}_{}.csv", prefix, case_name);
  log.write(log_path, comments);
  fmt::print("{:.1f} s {} at {:.1f}x real time -> {}\n", simulated_s, hw.replay ? "replayed" : "simulated", realtime_factor,
             (ctx.shown_dir() / log_path.filename()).string());
  finish_telemetry(tee);
  if (hw.replay) print_replay(*hw.replay, ctx.dir / fmt::format("replay_{}.csv", case_name));
}

int run_sequence(const config::Document& doc, const RunRequest& request, ExperimentRun& experiment) {
  const std::vector<std::string> names = experiment.case_names();
  const std::vector<std::size_t> cases = select_cases(doc, names, request.only_case);
  if (cases.empty()) return 2;
  std::vector<std::string> selected;
  for (const std::size_t i : cases) {
    if (!names.empty()) selected.push_back(names[i]);
  }
  RunContext ctx{{}, request, {}, {}, {}};
  if (!check_hardware(doc.name(), experiment.link(), selected, request, ctx.backend, ctx.realtime)) return 2;
  const TelemetrySource streamed = experiment.telemetry_source();
  const std::optional<runtime::TelemetryOptions> telemetry =
      telemetry_options(doc.name(), streamed.scenario, streamed.columns, request, ctx.realtime.has_value());
  if (!telemetry) return 2;
  ctx.telemetry = *telemetry;
  if (ctx.realtime) ctx.realtime->telemetry = *telemetry;

  // Only now, with everything loaded and checked, does the run leave a trace on disk.
  ctx.dir = request.open_run_dir(experiment.seed());
  if (ctx.realtime) ctx.realtime->dir = ctx.dir;
  experiment.print_header(ctx, cases);
  for (std::size_t k = 0; k < cases.size(); ++k) {
    if (!names.empty()) fmt::print("  [{}/{}] {} ... ", k + 1, cases.size(), names[cases[k]]);
    if (ctx.realtime) fmt::print("{}on {} in real time\n", names.empty() ? "  " : "", ctx.backend.describe());
    std::fflush(stdout);
    experiment.run_case(cases[k], ctx);
  }
  const Conclusion c = experiment.conclude(ctx);
  fmt::print("\nwritten: {}/{}\n", ctx.shown_dir().string(), c.written);
  print_sidecars(ctx.dir);
  if (request.plot && !c.plot_tool.empty()) plot_with(c.plot_tool.c_str(), ctx.dir, c.plot_args);
  if (c.comparison_failures > 0) {
    fmt::print("expected: {} figure{} failed in {} (shown for comparison, not judged)\n", c.comparison_failures,
               c.comparison_failures == 1 ? "" : "s", c.comparison);
  }
  if (c.failed_figures == 0) {
    fmt::print("PASSED\n");
    return 0;
  }
  fmt::print("FAILED ({} figure{})\n", c.failed_figures, c.failed_figures == 1 ? "" : "s");
  return 3;
}

mfb::JointEnvelope joint_envelope(const std::string& name, const models::JointModel& joint, const safety::JointLimits& limits) {
  mfb::JointEnvelope e;
  e.joint = name;
  e.agonist_force_N = models::force_ceiling_N(joint.agonist);
  e.antagonist_force_N = models::force_ceiling_N(joint.antagonist);
  e.supply_pressure_Pa = joint.supply_pressure_Pa;
  e.has_motor = joint.has_motor;
  e.motor_torque_Nm = joint.motor_max_torque_Nm;
  e.min_angle_rad = limits.min_angle_rad;
  e.max_angle_rad = limits.max_angle_rad;
  e.pressure_rate_Pa_per_s = limits.pressure_rate_Pa_per_s;
  return e;
}

BoardPlant board_for(const mfb::LinkConfig& link, double period_s, const hardware::HardwareRequest& request, std::string what) {
  return BoardPlant{period_s, link, {mfb::read_channel_map(config::Document::load_file(link.channel_map), request.joint_names)},
                    request.simulate, {}, std::move(what)};
}

std::string emulator_outage_error(const std::vector<sim::PlantFault>& faults) {
  for (const sim::PlantFault& f : faults) {
    if (!sim::is_outage(f.kind)) continue;
    return fmt::format("faults: {} at {:g} s is an outage of the in-process plant (its gate withholds the samples or switches the "
                       "board off); the board emulator cannot play it - over UDP the link's faults do (peha faults --link: loss "
                       "bursts, the board stalled, killed or rebooted). Remove it from the scenario's faults: list",
                       sim::fault_kind_name(f.kind), f.time_s);
  }
  return {};
}

std::optional<std::size_t> emulator_case(const config::Document& doc, const std::vector<std::string>& names, const std::string& given,
                                         const char* meaning, const std::string& also) {
  std::string cases = joined(names);
  if (!also.empty()) cases += ", " + also;
  if (given.empty() && names.size() > 1) {
    fmt::print(stderr, "error: {} has {} cases: give --case NAME ({}; the host's peha run --backend needs the same --case): {}\n", doc.name(),
               names.size(), meaning, cases);
    return std::nullopt;
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (given.empty() || names[i] == given) return i;
  }
  fmt::print(stderr, "error: no case named '{}' in {} (it has {})\n", given, doc.name(), cases);
  return std::nullopt;
}

bool has_link(const config::Document& doc, const std::optional<mfb::LinkConfig>& link) {
  if (!link) fmt::print(stderr, "config error: {}: no mfb: section (channel map, watchdogs): see docs/runtime.md\n", doc.name());
  return link.has_value();
}

}  // namespace peha::experiments
