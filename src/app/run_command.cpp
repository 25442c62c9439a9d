// `peha run`: the scenario's experiment from the registry, the options checked against what it
// takes, the run directory, the run.
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/app/video_option.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace peha::app {
namespace {

/// --backend chose other hardware than the default simulated plant (`sim:` is the default said aloud).
bool other_backend(const RunOptions& o) { return !o.backend.empty() && o.backend != "sim:" && o.backend != "sim"; }
/// --backend chose boards over UDP: a real-time run.
bool on_board(const RunOptions& o) { return o.backend.starts_with("udp://"); }

/// The options given on the command line that not every experiment takes, in --help order.
std::vector<std::string> checked_options_given(const RunOptions& o) {
  std::vector<std::string> given;
  const std::pair<const char*, bool> options[] = {
      {"--case", !o.only_case.empty()},
      {"--agonist-calibration", !o.calibration[0].empty()},
      {"--antagonist-calibration", !o.calibration[1].empty()},
      {"--goniometer-csv", !o.goniometer_csv.empty()},
      {"--backend", other_backend(o)},
      {"--force-trim-rate", o.force_trim_rate_1ps.has_value()},
      {"--fault", !o.faults.empty()},
      {"--gravity-identification", !o.gravity_identification.empty()},
  };
  for (const auto& [name, set] : options) {
    if (set) given.emplace_back(name);
  }
  return given;
}

/// The real-time options given (they apply to --backend runs only).
std::vector<std::string> realtime_options_given(const RunOptions& o) {
  std::vector<std::string> given;
  if (o.fifo_priority) given.emplace_back("--rt-priority");
  if (o.cpu) given.emplace_back("--cpu");
  if (!o.telemetry.empty()) given.emplace_back("--telemetry");
  if (o.telemetry_remote) given.emplace_back("--telemetry-remote");
  if (o.recover_after_s) given.emplace_back("--recover-after");
  return given;
}

/// Where --experiment applies: "an arm scenario's postures|goniometer|bandwidth".
std::string where_experiment_applies() {
  std::string where;
  for (const auto& e : experiment_registry()) {
    if (e.variants.size() == 1 && e.variants.front().name.empty()) continue;
    std::string names;
    for (const auto& v : e.variants) names += (names.empty() ? "" : "|") + v.name;
    where += fmt::format("{}a {} scenario's {}", where.empty() ? "" : ", ", e.key, names);
  }
  return where;
}

/// The entry's experiment --experiment chooses; nullptr after a message.
const RunVariant* choose_variant(const ExperimentEntry& entry, const RunOptions& options, const config::Document& doc) {
  if (entry.variants.size() == 1 && entry.variants.front().name.empty()) {
    if (options.experiment.empty()) return &entry.variants.front();
    fmt::print(stderr, "error: {}: experiment {} does not take --experiment: a {} scenario has one experiment "
                       "(--experiment chooses among {})\n", doc.name(), entry.key, entry.kind, where_experiment_applies());
    return nullptr;
  }
  for (const auto& v : entry.variants) {
    if (v.name == options.experiment) return &v;
  }
  std::string names;
  for (const auto& v : entry.variants) names += (names.empty() ? "" : "|") + v.name;
  fmt::print(stderr, "error: {} is an {} scenario: give --experiment {}\n", doc.name(), entry.kind, names);
  return nullptr;
}

std::string reason_for(const std::vector<Refusal>& refusals, const std::string& option, const RunVariant& variant) {
  for (const auto& r : refusals) {
    if (r.option == option) return r.reason;
  }
  std::string takes;
  for (const auto& a : variant.accepts) takes += (takes.empty() ? "" : ", ") + a;
  return fmt::format("not one of its options (it takes {})", takes.empty() ? std::string("none of them") : takes);
}

/// The first option given that the experiment does not take, as an error message; empty if none.
std::string refused_option(const ExperimentEntry& entry, const RunVariant& variant, const RunOptions& options,
                           const config::Document& doc) {
  const std::string what = fmt::format("{}: experiment {}{}", doc.name(), entry.key,
                                       variant.name.empty() ? "" : " --experiment " + variant.name);
  const std::vector<std::string> realtime = realtime_options_given(options);
  if (!realtime.empty() && !on_board(options)) {
    return fmt::format("{} applies to real-time runs on the board only: give --backend udp://A.B.C.D:PORT too", realtime.front());
  }
  for (const std::string& option : checked_options_given(options)) {
    if (std::find(variant.accepts.begin(), variant.accepts.end(), option) == variant.accepts.end()) {
      return fmt::format("{} does not take {}: {}", what, option, reason_for(variant.refusals, option, variant));
    }
    if (other_backend(options)) {
      for (const auto& r : variant.refused_on_board) {
        if (r.option == option) return fmt::format("{} with --backend does not take {}: {}", what, option, r.reason);
      }
    }
  }
  return {};
}

experiments::RunRequest make_request(const RunOptions& o) {
  experiments::RunRequest r;
  r.config = o.config;
  r.seed = o.seed;
  r.only_case = o.only_case;
  r.calibration[0] = o.calibration[0];
  r.calibration[1] = o.calibration[1];
  r.force_trim_rate_1ps = o.force_trim_rate_1ps;
  r.goniometer_csv = o.goniometer_csv;
  r.gravity_identification = o.gravity_identification;
  r.plot = o.plot;
  r.backend = o.backend;
  r.telemetry = o.telemetry;
  r.telemetry_remote = o.telemetry_remote;
  r.fifo_priority = o.fifo_priority.value_or(80);
  r.cpu = o.cpu.value_or(-1);
  r.recover_after_s = o.recover_after_s;
  r.faults = o.faults;
  return r;
}

}  // namespace

int run(const RunOptions& options) {
  return with_exit_codes([&] {
    const config::Document doc = config::Document::load_file(options.config);
    // The scenario says which experiment it describes; the options must be ones that experiment takes.
    const ExperimentEntry& entry = find_experiment(doc);
    const RunVariant* variant = choose_variant(entry, options, doc);
    if (!variant) return 2;
    if (const std::string refused = refused_option(entry, *variant, options, doc); !refused.empty()) {
      fmt::print(stderr, "error: {}\n", refused);
      return 2;
    }
    // The experiment opens the run directory once it has loaded and checked everything.
    RunDir run_dir(options.config, options.out_root, options.run_name);
    experiments::RunRequest request = make_request(options);
    request.open_run_dir = [&run_dir](std::uint64_t seed) { return run_dir.create(seed); };
    const int code = variant->run(doc, request);
    if (run_dir.created() && options.video) write_run_videos(doc, entry.key, run_dir.path());
    if (run_dir.created()) run_dir.link_latest();
    return code;
  });
}

}  // namespace peha::app
