// `peha run`: the scenario's experiment from the registry, the options checked against what it
// takes, the run directory, the run.
#include "peha/app/cli_checks.hpp"
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"
#include "peha/app/run_dir.hpp"
#include "peha/app/video_option.hpp"
#include "peha/hardware/backend_uri.hpp"

#include <fmt/format.h>

#include <memory>
#include <stdexcept>

namespace peha::app {
namespace {

/// An option of `peha run` that not every experiment takes: given or not, and which field of
/// experiments::Takes says an experiment takes it.
struct CheckedOption {
  const char* flag;
  bool given;
  bool experiments::Takes::*taken;
  /// Set for the options that shape the simulated world (the plant, the person): with hardware the
  /// world is the hardware's, so they apply in process only; this says what to do instead.
  const char* on_hardware = nullptr;
};

std::vector<CheckedOption> checked_options(const RunOptions& o) {
  using T = experiments::Takes;
  return {
      {"--case", !o.only_case.empty(), &T::cases},
      {"--agonist-calibration", !o.calibration[0].empty(), &T::calibration},
      {"--antagonist-calibration", !o.calibration[1].empty(), &T::calibration},
      {"--goniometer-csv", !o.goniometer_csv.empty(), &T::goniometer_csv,
       "with --backend the person's goniometer is the board's AD channel, in a replay the log's goniometer_deg; --goniometer-csv is for in-process runs on the simulated arm"},
      {"--force-trim-rate", o.force_trim_rate_1ps.has_value(), &T::force_trim},
      {"--fault", !o.faults.empty(), &T::faults,
       "with --backend the plant is the hardware's (the emulator's: give the faults in the scenario's faults: list)"},
      {"--gravity-identification", !o.gravity_identification.empty(), &T::gravity_identification},
  };
}

/// The real-time options given (they apply to --backend runs only; the telemetry streams in process too).
std::vector<std::string> realtime_options_given(const RunOptions& o) {
  std::vector<std::string> given;
  if (o.fifo_priority) given.emplace_back("--rt-priority");
  if (o.cpu) given.emplace_back("--cpu");
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

/// "E1 gravity compensation" or "arm --experiment postures (E3 postures)".
std::string run_name(const Experiment& e, const RunVariant& v) {
  return v.name.empty() ? v.title : fmt::format("{} --experiment {} ({})", e.key, v.name, v.title);
}

/// The experiments that take the option `taken` (for a refusal's message).
std::string who_takes(bool experiments::Takes::*taken) {
  std::string who;
  for (const auto& e : experiment_registry()) {
    for (const auto& v : e.variants) {
      if (v.takes.*taken) who += (who.empty() ? "" : ", ") + run_name(e, v);
    }
  }
  return who.empty() ? std::string("no experiment") : who;
}

/// The entry's experiment --experiment chooses; nullptr after a message.
const RunVariant* choose_variant(const Experiment& entry, const RunOptions& options, const config::Document& doc) {
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

/// The first option given that the experiment does not take, as an error message; empty if none.
/// Every message is derived from what the experiments declare (experiments::Takes).
std::string refused_option(const Experiment& entry, const RunVariant& variant, const RunOptions& options,
                           const config::Document& doc, const hardware::BackendUri& backend) {
  const std::string what = fmt::format("{}: {}", doc.name(), run_name(entry, variant));
  const std::vector<std::string> realtime = realtime_options_given(options);
  if (!realtime.empty() && backend.kind != hardware::BackendKind::kBoards) {
    return fmt::format("{} applies to real-time runs on the board only: give --backend udp://A.B.C.D:PORT too", realtime.front());
  }
  const bool boards = backend.kind == hardware::BackendKind::kBoards, replay = backend.kind == hardware::BackendKind::kReplay;
  if ((boards && !variant.takes.boards) || (replay && !variant.takes.replay)) {
    return fmt::format("{} does not take --backend {}: {}; --backend {} is for {}", what, backend.text,
                       variant.takes.why_not_hardware.empty() ? std::string("it runs in process only") : variant.takes.why_not_hardware,
                       boards ? "udp://" : "replay:", who_takes(boards ? &experiments::Takes::boards : &experiments::Takes::replay));
  }
  for (const CheckedOption& o : checked_options(options)) {
    if (!o.given) continue;
    if (!(variant.takes.*o.taken)) return fmt::format("{} does not take {}: {} is for {}", what, o.flag, o.flag, who_takes(o.taken));
    if (o.on_hardware && backend.kind != hardware::BackendKind::kSim) return fmt::format("{} does not take {}: {}", what, o.flag, o.on_hardware);
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
  r.telemetry_signals = o.telemetry_signals;
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
    const Experiment& entry = find_experiment(doc);
    const RunVariant* variant = choose_variant(entry, options, doc);
    if (!variant) return 2;
    hardware::BackendUri backend;
    try {
      backend = hardware::BackendUri::parse(options.backend);
    } catch (const std::invalid_argument& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return 2;
    }
    if (const std::string refused = refused_option(entry, *variant, options, doc, backend); !refused.empty()) {
      fmt::print(stderr, "error: {}\n", refused);
      return 2;
    }
    // What the run reads; the run folder may not hold any of it (committing would replace it).
    std::vector<std::filesystem::path> inputs = scenario_inputs(options.config);
    for (const std::filesystem::path& p : {options.calibration[0], options.calibration[1], options.goniometer_csv,
                                           options.gravity_identification}) {
      if (!p.empty()) inputs.push_back(p);
    }
    if (backend.kind == hardware::BackendKind::kReplay) inputs.push_back(backend.replay_log);
    // The experiment opens the run directory once it has loaded and checked everything.
    RunDir run_dir(options.config, options.out_root, options.run_name, inputs);
    experiments::RunRequest request = make_request(options);
    request.open_run_dir = [&run_dir](std::uint64_t seed) { return run_dir.create(seed); };
    request.run_folder = run_dir.final_path();
    std::unique_ptr<experiments::ExperimentRun> experiment;
    try {
      experiment = variant->make_run(doc, request);
    } catch (const experiments::RequestError& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return 2;
    }
    const int code = experiments::run_sequence(doc, request, *experiment);
    if (run_dir.created() && options.video) write_run_videos(doc, entry.key, run_dir.path());
    // A run that ended with its verdict (passed or failed) is a result; one that stopped on an
    // error stays in its partial folder (RunDir says where) and leaves the earlier run as it was.
    if (run_dir.created() && (code == 0 || code == 3)) {
      run_dir.commit();
      fmt::print("run folder: {}\n", run_dir.path().string());
    }
    return code;
  });
}

}  // namespace peha::app
