#include "peha/experiments/run_request.hpp"

#include "peha/io/udp_socket.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <spawn.h>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace peha::experiments {

std::optional<HardwareRunOptions> realtime_options(const RunRequest& request) {
  HardwareRunOptions o;
  try {
    o.backend = hardware::BackendUri::parse(request.backend);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return std::nullopt;
  }
  o.realtime.fifo_priority = request.fifo_priority;
  o.realtime.cpu = request.cpu;
  o.recover_after_s = request.recover_after_s.value_or(-1.0);
  return o;
}

std::optional<runtime::TelemetryOptions> telemetry_options(const std::string& doc_name, const runtime::TelemetryOptions& scenario,
                                                          const std::vector<std::string>& columns, const RunRequest& request, bool on_boards) {
  runtime::TelemetryOptions o = scenario;
  o.allow_remote = request.telemetry_remote;
  if (!request.telemetry_signals.empty()) o.signals = request.telemetry_signals;
  try {
    if (!request.telemetry.empty()) o.destination = io::parse_udp_endpoint(request.telemetry);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: --telemetry {}: {}\n", request.telemetry, e.what());
    return std::nullopt;
  }
  if (!o.destination) {
    if (request.telemetry_signals.empty()) return o;
    fmt::print(stderr, "error: --telemetry-signal needs a destination: --telemetry udp://127.0.0.1:PORT, or telemetry.destination in {}\n",
               doc_name);
    return std::nullopt;
  }
  if (columns.empty()) {
    if (request.telemetry.empty() && request.telemetry_signals.empty()) {
      fmt::print("  telemetry: this experiment has no per-cycle log; {}'s telemetry.destination streams nothing\n", doc_name);
      o.destination.reset();
      return o;
    }
    fmt::print(stderr, "error: {}: this experiment has no per-cycle log, so --telemetry has nothing to stream\n", doc_name);
    return std::nullopt;
  }
  try {
    runtime::check_telemetry(o, columns, on_boards ? runtime::RealtimeHarness::telemetry_extras() : std::vector<std::string>{});
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}: {}\n", doc_name, e.what());
    return std::nullopt;
  }
  return o;
}

bool check_board_addresses(const std::string& doc_name, const mfb::LinkConfig& link, const HardwareRunOptions& realtime) {
  try {
    (void)mfb::board_endpoints(link, realtime.backend.boards);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}: {}\n", doc_name, e.what());
    return false;
  }
  return true;
}

/// The run's hardware, checked before anything is written: over the board one case, the mfb:
/// section and the addresses; a replay one case (a log is one run). False (after a message) when
/// the request cannot run; `realtime` is set only for a run on boards.
bool check_hardware(const std::string& doc_name, const mfb::LinkConfig* link, const std::vector<std::string>& cases, const RunRequest& request,
                    hardware::BackendUri& uri, std::optional<HardwareRunOptions>& realtime) {
  std::optional<HardwareRunOptions> options = realtime_options(request);
  if (!options) return false;
  uri = options->backend;
  if (uri.kind == hardware::BackendKind::kSim) return true;
  if (cases.size() > 1) {
    std::string names;
    for (const auto& n : cases) names += (names.empty() ? "" : ", ") + n;
    fmt::print(stderr, "error: --backend {} runs one case (a board serves one plant, a log recorded one run; with peha "
                       "mfb-emulator the same --case): give --case NAME ({}), the cases of {}\n", uri.text, names, doc_name);
    return false;
  }
  if (uri.kind == hardware::BackendKind::kReplay) return true;
  if (!link) {
    fmt::print(stderr, "config error: {}: --backend {} needs an mfb: section (channel map, watchdogs)\n", doc_name, uri.text);
    return false;
  }
  realtime = std::move(options);
  return check_board_addresses(doc_name, *link, *realtime);
}

void print_realtime(const BoardRunResult& rr, const std::filesystem::path& timing_dir) {
  fmt::print("  real-time setup: {}\n", rr.realtime.summary());
  fmt::print("{}\n", rr.timing.table());
  const auto& l = rr.link;
  fmt::print("  link: {} commands sent ({} send failures), states accepted {}, dropped: foreign source {}, foreign "
             "session {}, duplicate {}, stale {}, malformed {}, unauthenticated {}; gaps {}; replies later than receive_timeout {}; cycles without a "
             "new sample {}; implausible samples {}; clamped DA codes {}\n",
             l.commands_sent, l.send_failures, l.received.accepted, l.received.foreign_source, l.received.foreign_session,
             l.received.duplicate, l.received.stale, l.received.malformed, l.received.unauthenticated, l.received.gaps, l.late_replies, l.replies_missing,
             l.implausible_samples, l.clamped_outputs);
  fmt::print("  log: {} rows written ({} dropped) -> {}; {} fault dump(s); telemetry datagrams {}\n  lifecycle:\n", rr.logged_rows,
             rr.dropped_rows, rr.log_file, rr.fault_dumps.size(), rr.telemetry_datagrams);
  for (const auto& b : rr.boards) {
    const auto& s = b.link;
    fmt::print("  board '{}': {} commands, {} states accepted, replies later than receive_timeout {}, cycles without a new sample {}, "
               "dropped {}; round trip median / p99 / p99.9 / max {:.1f} / {:.1f} / {:.1f} / {:.1f} us, mean {:.1f} us ({} measured)\n",
               b.name, s.commands_sent, s.received.accepted, s.late_replies, s.replies_missing,
               s.received.foreign_source + s.received.foreign_session + s.received.duplicate + s.received.stale + s.received.malformed +
                   s.received.unauthenticated,
               b.rtt.percentile(50) * 1e6, b.rtt.percentile(99) * 1e6, b.rtt.percentile(99.9) * 1e6, s.rtt_max_s * 1e6,
               s.rtt_count ? s.rtt_sum_s / static_cast<double>(s.rtt_count) * 1e6 : 0.0, s.rtt_count);
  }
  for (const auto& e : rr.lifecycle) fmt::print("    {}\n", e);
  rr.timing.write_csv(timing_dir);
}

void print_replay(const hardware::ReplayBackend& replay, const std::filesystem::path& commands_csv) {
  replay.write_commands(commands_csv, {fmt::format("replay of {}: recorded_* the log's commands, replayed_* this run's", replay.info().name)});
  const hardware::ReplayBackend::Difference d = replay.max_difference();
  fmt::print("  replay: {} of {} recorded rows fed to the controller; its commands vs the recorded ones: max |pressure difference| "
             "{:.4g} MPa, max |motor torque difference| {:.4g} Nm -> {}\n",
             replay.replayed(), replay.rows(), d.pressure_MPa, d.motor_Nm, commands_csv.string());
}

namespace {

std::string find_python() {
  // Debian's interpreter carries numpy/matplotlib; the python3 first on PATH may not.
  return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}

/// Runs argv[0] (searched on PATH) with `args` and waits; true when it exited with 0.
bool run_and_wait(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return false;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return false;
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

void plot_with(const char* tool, const std::filesystem::path& dir, const std::vector<std::string>& args) {
  std::fflush(stdout);  // the plotter writes to the same terminal
  const std::filesystem::path script = std::filesystem::path(PEHA_SOURCE_DIR) / "tools" / tool;
  std::vector<std::string> argv = {find_python(), script.string(), dir.string()};
  argv.insert(argv.end(), args.begin(), args.end());
  if (!run_and_wait(argv)) {
    fmt::print(stderr, "warning: {} failed (needs /usr/bin/python3 with matplotlib: run scripts/install-deps.sh); "
                       "the data in {} are complete\n", tool, dir.string());
  }
}

ProgressPrinter::ProgressPrinter(std::string what) : what_(std::move(what)), tty_(isatty(fileno(stdout)) != 0) {}

void ProgressPrinter::update(double done, double total, const std::string& detail) {
  const int percent = total > 0 ? static_cast<int>(100.0 * done / total) : 100;
  if (tty_) {
    if (percent == last_) return;
    const int filled = percent * 30 / 100;
    fmt::print("\r  {:<14} [{:<30}] {:3d} % {}", what_, std::string(static_cast<std::size_t>(filled), '#'), percent, detail);
    if (percent >= 100) fmt::print("\n");
  } else {
    if (percent / 10 == last_ / 10 && last_ >= 0) return;
    fmt::print("  {:<14} {:3d} % {}\n", what_, percent / 10 * 10, detail);
  }
  last_ = percent;
  std::fflush(stdout);
}

}  // namespace peha::experiments
