#include "peha/experiments/faults/link_faults.hpp"
#include "peha/io/backend.hpp"

#include "peha/experiments/e1_gravity/e1_realtime.hpp"
#include "peha/experiments/faults/fault_matrix.hpp"
#include "peha/mfb/udp_backend.hpp"
#include "peha/models/units.hpp"
#include "peha/runtime/child_process.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/verdict.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <chrono>
#include <thread>
#include <stdexcept>

namespace peha::experiments {
namespace {

using io::kNaN;

/// `peha mfb-emulator` as a child process, with the port it names once it listens; signalled by the
/// row (stall, kill), ended with SIGTERM (the ChildProcess kills what is left).
struct Emulator {
  runtime::ChildProcess process;
  int port = 0;
  explicit Emulator(const std::vector<std::string>& argv) : process(argv) {
    port = runtime::parse_listening_port(process.wait_for_line("listening on udp://", 10.0));
    if (port == 0) {
      throw std::runtime_error(fmt::format("peha faults --link: the emulator ({}) did not start listening within 10 s; it wrote:\n{}", argv[0],
                                           process.output()));
    }
  }
  ~Emulator() {
    process.signal(SIGCONT);  // a stalled one must be able to take the SIGTERM
    (void)process.stop(SIGTERM, 2.0);
  }
  Emulator(const Emulator&) = delete;
  Emulator& operator=(const Emulator&) = delete;
};

/// How a row injects its fault: emulator options, and/or a signal to the emulator at a host cycle.
struct LinkFault {
  std::string name;
  std::string injects;
  bool expect_detection;
  std::vector<std::string> emulator_args;  ///< "{t}" is replaced by the injection time
  /// kSpoof: from the injection on, every cycle, another socket of this machine sends the host a
  /// state packet of its session, authenticated with the link's key (an insider), a wild encoder
  /// reading in it and a sequence far ahead. kReboot: the emulator killed and a successor (started
  /// before the run, waiting for the port) takes over at once. kHostKill: the host is `peha run` in
  /// its own process, killed; the board is observed (run_host_killed).
  enum class Signal { kNone, kStall, kKill, kSpoof, kReboot, kHostKill } signal = Signal::kNone;
  bool from_start = false;  ///< injected for the whole run (random link faults)
  /// Timed on the board's clock (the emulator's simulated time, a few ms off the host's cycle count):
  /// detection is measured in the log, whose t_s is the board's time stamp, to the first latched flag.
  bool board_clock = false;
  std::string expect_by = {};  ///< the designed detector (LinkFaultRow::expect_by)
};

constexpr double kStall_s = 0.2;

const std::vector<LinkFault>& link_faults() {
  using S = LinkFault::Signal;
  static const std::vector<LinkFault> faults = {
      {"loss_1pct", "1 % of the board's state packets dropped at random, the whole run", false, {"--loss", "0.01"}, S::kNone, true},
      {"loss_5pct", "5 % of the state packets dropped at random, the whole run", false, {"--loss", "0.05"}, S::kNone, true},
      {"loss_burst_1", "exactly 1 state packet dropped at the injection: one cycle holds its command, far inside host_watchdog_ms",
       false, {"--loss-burst-at", "{t}", "--loss-burst-packets", "1"}, S::kNone},
      {"loss_burst_5", "5 consecutive state packets dropped: 5 silent cycles reach the 5-cycle count, but 5 ms < host_watchdog_ms "
       "(20 ms) and the host faults only when both hold: ridden out",
       false, {"--loss-burst-at", "{t}", "--loss-burst-packets", "5"}, S::kNone},
      {"loss_burst_50", "50 consecutive state packets dropped: 50 ms without a sample > host_watchdog_ms (20 ms)", true,
       {"--loss-burst-at", "{t}", "--loss-burst-packets", "50"}, S::kNone, false, false, "backend silent"},
      {"loss_burst_all", "every state packet dropped from the injection to the end", true,
       {"--loss-burst-at", "{t}", "--loss-burst-packets", "0"}, S::kNone, false, false, "backend silent"},
      {"duplicate_5pct", "5 % of the state packets sent twice, the whole run", false, {"--duplicate", "0.05"}, S::kNone, true},
      {"reorder_5pct", "5 % of the state packets held back behind the next, the whole run", false, {"--reorder", "0.05"}, S::kNone, true},
      {"corrupt_5pct", "one bit flipped in 5 % of the state packets, the whole run", false, {"--corrupt", "0.05"}, S::kNone, true},
      {"delay_3ms", "every state packet leaves 3 ms late, the whole run", false, {"--delay-ms", "3"}, S::kNone, true},
      {"estop", "the board's e-stop input active from the injection to the end", true, {"--estop-at", "{t}", "--estop-for", "1000"}, S::kNone, false, true},
      {"board_stall_200ms", "the emulator stopped (SIGSTOP) for 200 ms, then continued", true, {}, S::kStall, false},
      {"board_killed", "the emulator killed (SIGKILL)", true, {}, S::kKill, false},
      {"board_reboot", "the emulator killed (SIGKILL) and a fresh one (new boot id, no session, disarmed, its plant restarted) on the "
       "same port within a millisecond, as a board's reset",
       true, {}, S::kReboot, false, false, "board reboot"},
      {"host_killed", "the host (peha run, its own process) killed (SIGKILL) while the board's outputs are armed; the board's own "
       "watchdog must make them safe (figures: the board's plant, from the kill)",
       true, {}, S::kHostKill, false, false, "board watchdog"},
      {"spoofing_sender", "another port sends the host state packets of its session with the key, a wild encoder reading, every cycle",
       false, {}, S::kSpoof, false},
  };
  return faults;
}

/// The monotonic ns in an emulator line "... (monotonic N ns)" after `marker` (0 if absent).
std::int64_t monotonic_after(const std::string& output, const std::string& marker) {
  const auto at = output.find(marker);
  if (at == std::string::npos) return 0;
  const auto m = output.find("monotonic ", at);
  return m == std::string::npos ? 0 : std::strtoll(output.c_str() + m + 10, nullptr, 10);
}

/// The emulator's argv for `c`, with the row's watchdog override.
std::vector<std::string> emulator_argv(const LinkFaultOptions& options, const E1Case& c) {
  std::vector<std::string> argv = {options.peha_binary.string(), "mfb-emulator", "--config", options.config.string(), "--case", c.name,
                                   "--rt-priority", "0", "--fault-seed", std::to_string(options.seed)};
  if (options.board_watchdog_ms) argv.insert(argv.end(), {"--watchdog-ms", fmt::format("{:g}", *options.board_watchdog_ms)});
  return argv;
}

/// The row's detection and the plant's figures after the injection, from the run's log and lifecycle.
LinkFaultRow detect_from_log(const E1Scenario& s, const LinkFault& fault, double t_inject, const E1RealtimeResult& r, std::int64_t inject_ns,
                             std::int64_t fault_ns) {
  LinkFaultRow row;
  row.fault = fault.name;
  row.injects = fault.injects;
  row.expect_detection = fault.expect_detection;
  row.expect_by = fault.expect_by;
  row.fault_time_s = fault.from_start ? 0.0 : t_inject;
  const auto [fault_t, reason] = first_lifecycle_fault(r.lifecycle);
  row.detected = r.faults > 0 || r.e1.faults > 0;
  row.by = row.detected ? (reason.empty() ? r.e1.fault_reason : reason) : "-";
  row.detection_ms = !fault.from_start && std::isfinite(fault_t) ? (fault_t - t_inject) * 1e3 : kNaN;
  if (inject_ns != 0) row.detection_ms = fault_ns != 0 ? static_cast<double>(fault_ns - inject_ns) * 1e-6 : kNaN;
  const auto cols = runtime::read_csv_log_columns(r.log_file, {"t_s", "velocity_radps", "agonist_loadcell_N", "antagonist_loadcell_N", "fault_flags"});
  const std::size_t n = cols[0].size();
  if (fault.board_clock) {
    row.detection_ms = kNaN;
    for (std::size_t k = 0; k < n && k < cols[4].size(); ++k) {
      if (cols[0][k] >= t_inject - 0.5 * s.period_s && cols[4][k] != 0 && std::isfinite(cols[4][k])) {
        row.detection_ms = (cols[0][k] - t_inject) * 1e3;
        break;
      }
    }
  }
  row.detection_cycles = row.detection_ms / (s.period_s * 1e3);
  // The host's fault disables the outputs in the same cycle (LimitedBackend's safe state, or the
  // board disarming on the disabled command); the board's own e-stop and stall are disarmed on the board.
  row.safe_ms = row.detected ? row.detection_ms : kNaN;
  const double from_s = std::max(row.fault_time_s, r.e1.tare_slack_s);
  row.min_tension_N = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < n; ++k) {
    if (cols[0][k] < from_s) continue;
    if (k < cols[1].size() && std::isfinite(cols[1][k])) row.peak_speed_degps = std::max(row.peak_speed_degps, models::rad_to_deg(std::abs(cols[1][k])));
    for (int m : {2, 3}) {
      if (k >= cols[static_cast<std::size_t>(m)].size() || !std::isfinite(cols[static_cast<std::size_t>(m)][k])) continue;
      row.peak_force_N = std::max(row.peak_force_N, cols[static_cast<std::size_t>(m)][k]);
      row.min_tension_N = std::min(row.min_tension_N, cols[static_cast<std::size_t>(m)][k]);
    }
  }
  if (!std::isfinite(row.min_tension_N)) row.min_tension_N = kNaN;
  return row;
}

/// One row of the link matrix from its run: detection, the limits exceeded (and why physics forbids
/// them), the log's completeness and the link's counters.
LinkFaultRow link_fault_row(const E1Scenario& s, const LinkFault& fault, double t_inject, const E1RealtimeResult& r, std::int64_t inject_ns,
                            std::int64_t fault_ns) {
  LinkFaultRow row = detect_from_log(s, fault, t_inject, r, inject_ns, fault_ns);
  for (const safety::Check& ch : r.e1.verdict.checks) {
    const bool envelope = ch.figure.ends_with("peak force") || ch.figure.ends_with("highest pressure") || ch.figure.ends_with("peak motor torque") ||
                          ch.figure.ends_with("lowest angle") || ch.figure.ends_with("highest angle");
    if (envelope && !ch.passed()) ++row.limits_exceeded, row.limits += (row.limits.empty() ? "" : "; ") + ch.describe();
  }
  if (row.limits_exceeded > 0 && fault.name == "estop") row.physics_forbids = physics_forbids(sim::FaultKind::kEstop);
  if (row.limits_exceeded > 0 && fault.expect_detection && fault.emulator_args.size() > 1 && fault.emulator_args.front() == "--loss-burst-at") {
    row.physics_forbids = "a burst longer than host_watchdog_ms faults the host, which disables its outputs: the board vents both muscles "
                          "(motor off), and the payload falls to its stop - the host sees it once the samples return (a silent link is a stop category 0, "
                          "as the stall row)";
  }
  if (row.limits_exceeded > 0 && fault.signal == LinkFault::Signal::kStall) {
    row.physics_forbids = "the stalled board runs again with no command for longer than its watchdog: it disarms its outputs itself (stop "
                          "category 0, as the e-stop), and the host, faulted on the silent backend, keeps them disabled: no output is left "
                          "to govern a descent";
  }
  const auto expected_rows = static_cast<std::uint64_t>(std::llround(s.duration_s / s.period_s));
  // A row per cycle with a new sample; a cycle without one holds the command and logs nothing.
  row.log_complete = r.dropped_rows == 0 && r.logged_rows + r.e1.missed_samples >= expected_rows;
  const mfb::ReceiveCounters& rc = r.link.received;
  row.lost = r.link.replies_missing;
  row.late = r.link.late_replies;
  row.corrupt = rc.malformed;
  row.duplicate = rc.duplicate;
  row.stale = rc.stale;
  row.foreign = rc.foreign_session + rc.foreign_source;
  row.unauthenticated = rc.unauthenticated;
  row.accepted = rc.accepted;
  return row;
}

LinkFaultRow run_one(const E1Scenario& scenario, const E1Case& c, const LinkFaultOptions& options, const LinkFault& fault) {
  const double t_inject = options.fault_at_s;
  std::vector<std::string> argv = emulator_argv(options, c);
  for (const std::string& a : fault.emulator_args) argv.push_back(a == "{t}" ? fmt::format("{:g}", t_inject) : a);
  std::vector<std::string> first_argv = argv;
  first_argv.insert(first_argv.end(), {"--port", "0"});
  Emulator emulator(first_argv);
  // The rebooted board: a second emulator on the same port, loaded and waiting for the port to be
  // free, so that the "reboot" takes as long as a board's reset, not a process start.
  std::optional<runtime::ChildProcess> successor;
  if (fault.signal == LinkFault::Signal::kReboot) {
    std::vector<std::string> next = argv;
    next.insert(next.end(), {"--port", std::to_string(emulator.port), "--bind-retry", "60"});
    successor.emplace(next);
    if (successor->wait_for_line("waiting for udp://", 10.0).empty()) {
      throw std::runtime_error(fmt::format("peha faults --link: the rebooted board did not start; it wrote:\n{}", successor->output()));
    }
  }

  E1Scenario s = scenario;
  s.duration_s = t_inject + options.after_fault_s;
  if (options.host_watchdog_ms) s.lifecycle.host_watchdog_s = *options.host_watchdog_ms * 1e-3;
  HardwareRunOptions o;
  o.backend = hardware::BackendUri::parse(fmt::format("udp://127.0.0.1:{}", emulator.port));
  o.realtime.fifo_priority = 0;  // both processes share the machine's cores: no SCHED_FIFO
  o.realtime.lock_memory = false;
  o.quiet = true;
  o.dir = options.dir / "link" / fault.name;
  std::filesystem::remove_all(o.dir);
  std::filesystem::create_directories(o.dir);

  // The spoofer: its socket and the key made before the run (the loop only sends).
  io::UdpSocket stranger({0x7F000001u, 0});
  const mfb::LinkKey key = mfb::load_link_key(s.link->key_file);
  std::array<std::uint8_t, mfb::kMaxPacketSize> spoof{};
  std::size_t spoof_bytes = 0;
  std::int64_t kill_ns = 0, fault_ns = 0;  // host monotonic clock: the injection, the first fault
  E1RealtimeResult r;
  const auto inject_cycle = static_cast<std::uint64_t>(std::llround(t_inject / s.period_s));
  const auto resume_cycle = inject_cycle + static_cast<std::uint64_t>(std::llround(kStall_s / s.period_s));
  static_cast<BoardRunResult&>(r) = run_on_hardware(
      e1_hardware(s, c), s.lifecycle, o,
      {c.name, s.duration_s, o.dir / "e1.csv", e1_log_columns(), {fmt::format("peha faults --link: {} ({})", fault.name, fault.injects)}},
      [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
        const mfb::UdpBackend& board = hw.boards->board(0);
        if (fault.signal == LinkFault::Signal::kSpoof) {
          mfb::StatePacket fake;
          fake.session_id = board.session_id();
          fake.sequence = 0x7FFFFFF0u;
          fake.encoder[0] = 12345;  // a wild angle if it were applied
          spoof_bytes = mfb::encode(fake, key, spoof);
        }
        if (hooks.supervisor) {  // when the run faulted, on the host's clock (the board's events are on the same clock)
          hooks.supervisor->on_fault = [&fault_ns, then = hooks.supervisor->on_fault](const char* why) {
            if (fault_ns == 0) fault_ns = io::monotonic_ns();
            if (then) then(why);
          };
        }
        if (fault.signal != LinkFault::Signal::kNone) {
          hooks.wait = [&, wait = hooks.wait, cycle = std::uint64_t{0}]() mutable {
            if (cycle == inject_cycle && (fault.signal == LinkFault::Signal::kKill || fault.signal == LinkFault::Signal::kReboot)) {
              kill_ns = io::monotonic_ns();
              emulator.process.signal(SIGKILL);
            }
            if (cycle == inject_cycle && fault.signal == LinkFault::Signal::kStall) emulator.process.signal(SIGSTOP);
            if (cycle == resume_cycle && fault.signal == LinkFault::Signal::kStall) emulator.process.signal(SIGCONT);
            if (cycle >= inject_cycle && spoof_bytes > 0) {
              stranger.send_to(board.local(), std::span<const std::uint8_t>(spoof.data(), spoof_bytes));
            }
            ++cycle;
            wait();
          };
        }
        r.e1 = run_e1_on(s, c, *hw.backend, nullptr, &sink, hooks);
        return r.e1.verdict;
      });

  // The board's side of the injection, on the host's monotonic clock (the emulator prints it).
  std::int64_t inject_ns = kill_ns;
  if (fault.emulator_args.size() > 1 && fault.emulator_args.front() == "--loss-burst-at") {
    (void)emulator.process.stop(SIGTERM, 2.0);
    inject_ns = monotonic_after(emulator.process.output(), "loss burst from");
  }
  if (successor) (void)successor->stop(SIGTERM, 2.0);

  return link_fault_row(s, fault, t_inject, r, inject_ns, fault_ns);
}

/// The host killed: `peha run` over UDP in its own process, SIGKILLed once its run has been live for
/// fault_at_s; nothing on the host side is left to notice, so the row watches the board: the
/// emulator's watchdog trip (it prints it, on the host's monotonic clock) and its plant's truth
/// (--truth-csv) from the kill to the end.
LinkFaultRow run_host_killed(const E1Scenario& scenario, const E1Case& c, const LinkFaultOptions& options, const LinkFault& fault) {
  const std::filesystem::path dir = options.dir / "link" / fault.name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::vector<std::string> argv = emulator_argv(options, c);
  argv.insert(argv.end(), {"--port", "0", "--truth-csv", (dir / "board_truth.csv").string()});
  Emulator emulator(argv);
  runtime::ChildProcess host({options.peha_binary.string(), "run", "--config", options.config.string(), "--case", c.name, "--backend",
                              fmt::format("udp://127.0.0.1:{}", emulator.port), "--rt-priority", "0", "--no-plot", "-o", dir.string(), "-n",
                              "host"});
  const std::string armed = emulator.process.wait_for_line("outputs armed", 30.0);
  if (armed.empty()) {
    (void)host.stop(SIGKILL, 2.0);
    throw std::runtime_error(fmt::format("peha faults --link: host_killed: the host never armed the board; the host wrote:\n{}\nthe board:\n{}",
                                         host.output(), emulator.process.output()));
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(options.fault_at_s));
  const std::int64_t kill_ns = io::monotonic_ns();
  host.signal(SIGKILL);
  (void)host.wait(5.0);
  std::this_thread::sleep_for(std::chrono::duration<double>(options.after_fault_s));
  (void)emulator.process.stop(SIGTERM, 10.0);
  const std::string out = emulator.process.output();
  std::ofstream(dir / "emulator.txt") << out;
  std::ofstream(dir / "host.txt") << host.output();

  LinkFaultRow row;
  row.fault = fault.name;
  row.injects = fault.injects;
  row.expect_detection = fault.expect_detection;
  row.expect_by = fault.expect_by;
  row.fault_time_s = options.fault_at_s;
  // The designed bound: the board's configured watchdog, plus 5 ms for its loop's period and the
  // scheduling of two unprivileged processes on a shared machine.
  row.max_safe_ms = scenario.link->board_watchdog_s * 1e3 + 5.0;
  const std::int64_t trip_ns = monotonic_after(out, "host lost");
  row.detected = trip_ns != 0;
  row.by = row.detected ? "board watchdog (host lost)" : "-";
  row.detection_ms = row.detected ? static_cast<double>(trip_ns - kill_ns) * 1e-6 : kNaN;
  row.detection_cycles = row.detection_ms / (scenario.period_s * 1e3);
  const auto cols = runtime::read_csv_log_columns(dir / "board_truth.csv", {"t_s", "mono_ns", "angle_rad", "agonist_loadcell_N",
                                                                             "antagonist_loadcell_N", "armed", "motor_off"});
  const std::size_t n = cols[0].size();
  row.safe_ms = kNaN;
  row.min_tension_N = std::numeric_limits<double>::infinity();
  constexpr std::size_t kSpeedWindow = 10;  // steps: the angle's difference over 10 ms (the sensor's noise averaged)
  std::size_t first = n;
  for (std::size_t k = 0; k < n; ++k) {
    if (static_cast<std::int64_t>(cols[1][k]) < kill_ns) continue;
    if (first == n) first = k;
    if (!std::isfinite(row.safe_ms) && cols[5][k] == 0 && cols[6][k] != 0) row.safe_ms = (cols[1][k] - static_cast<double>(kill_ns)) * 1e-6;
    row.peak_force_N = std::max({row.peak_force_N, cols[3][k], cols[4][k]});
    row.min_tension_N = std::min({row.min_tension_N, cols[3][k], cols[4][k]});
    if (k >= kSpeedWindow && cols[0][k] > cols[0][k - kSpeedWindow]) {
      const double speed_radps = std::abs(cols[2][k] - cols[2][k - kSpeedWindow]) / (cols[0][k] - cols[0][k - kSpeedWindow]);
      row.peak_speed_degps = std::max(row.peak_speed_degps, models::rad_to_deg(speed_radps));
    }
  }
  if (!std::isfinite(row.min_tension_N)) row.min_tension_N = kNaN;
  // The envelope as the verdict checks it on the host's runs: the joint's range (give or take the
  // verdict's tolerance), now on the board's plant.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t k = first; k < n; ++k) lo = std::min(lo, cols[2][k]), hi = std::max(hi, cols[2][k]);
  const safety::JointLimits& range = scenario.limits.joints[0];
  for (const auto& [what, angle] : {std::pair{"lowest angle", lo}, std::pair{"highest angle", hi}}) {
    if (first < n && (angle < range.min_angle_rad - safety::kRangeTolerance_rad || angle > range.max_angle_rad + safety::kRangeTolerance_rad)) {
      ++row.limits_exceeded;
      row.limits += fmt::format("{}joint {} {:.2f} deg outside [{:.2f}, {:.2f}] deg (board's plant)", row.limits.empty() ? "" : "; ", what,
                                models::rad_to_deg(angle), models::rad_to_deg(range.min_angle_rad - safety::kRangeTolerance_rad),
                                models::rad_to_deg(range.max_angle_rad + safety::kRangeTolerance_rad));
    }
  }
  if (row.limits_exceeded > 0) {
    row.physics_forbids = "the board's safe state is its designed one - motor off, both muscles vented over vent_s - and with no host "
                          "left nothing governs a descent: the payload falls to the stop, as after an e-stop (stop category 0)";
  }
  // The board's record runs on from the kill to the end (a step per period while no command comes).
  row.log_complete = first < n && (cols[1][n - 1] - static_cast<double>(kill_ns)) * 1e-9 >= 0.9 * options.after_fault_s;
  return row;
}

}  // namespace

const std::vector<std::string>& link_fault_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const LinkFault& f : link_faults()) v.push_back(f.name);
    return v;
  }();
  return names;
}

std::vector<LinkFaultRow> run_link_faults(const E1Scenario& scenario, const LinkFaultOptions& options,
                                          const std::function<void(const LinkFaultRow&)>& progress) {
  if (!scenario.link) throw std::invalid_argument("peha faults --link: the scenario has no mfb: section (channel map, watchdogs)");
  std::string all;
  for (const std::string& n : link_fault_names()) all += (all.empty() ? "" : "|") + n;
  for (const std::string& w : options.faults) {
    if (std::find(link_fault_names().begin(), link_fault_names().end(), w) == link_fault_names().end()) {
      throw std::invalid_argument(fmt::format("peha faults --link: no link fault '{}' (there are {})", w, all));
    }
  }
  E1Case c = scenario.cases.front();
  if (!options.case_name.empty()) {
    const auto it = std::find_if(scenario.cases.begin(), scenario.cases.end(), [&](const E1Case& e) { return e.name == options.case_name; });
    if (it == scenario.cases.end()) throw std::invalid_argument(fmt::format("peha faults: no case named '{}'", options.case_name));
    c = *it;
  }
  std::vector<LinkFaultRow> out;
  const LinkFault nominal{"none", "nothing injected", false, {}, LinkFault::Signal::kNone, true};
  out.push_back(run_one(scenario, c, options, nominal));
  if (progress) progress(out.back());
  for (const LinkFault& f : link_faults()) {
    if (!options.faults.empty() && std::find(options.faults.begin(), options.faults.end(), f.name) == options.faults.end()) continue;
    out.push_back(f.signal == LinkFault::Signal::kHostKill ? run_host_killed(scenario, c, options, f) : run_one(scenario, c, options, f));
    if (progress) progress(out.back());
  }
  return out;
}

void write_link_faults(const std::filesystem::path& dir, const std::vector<LinkFaultRow>& rows, const std::string& scenario_name,
                       const LinkFaultOptions& options) {
  auto num = [](double v, const char* f) { return std::isfinite(v) ? fmt::format(fmt::runtime(f), v) : std::string("-"); };
  std::ofstream csv(dir / "faults_link.csv");
  csv << "fault,fault_time_s,expect_detection,expect_by,detected,by,detection_ms,detection_cycles,safe_ms,max_safe_ms,peak_force_N,peak_speed_degps,min_tension_N,"
         "limits_exceeded,physics_forbids,log_complete,outcome_met,lost,late,corrupt,duplicate,stale,foreign,unauthenticated,accepted\n";
  for (const LinkFaultRow& r : rows) {
    csv << fmt::format("{},{:.3f},{},\"{}\",{},\"{}\",{},{},{},{},{:.1f},{:.2f},{},{},\"{}\",{},{},{},{},{},{},{},{},{},{}\n", r.fault,
                       r.fault_time_s, r.expect_detection ? 1 : 0, r.expect_by, r.detected ? 1 : 0, r.by, num(r.detection_ms, "{:.1f}"),
                       num(r.detection_cycles, "{:.0f}"), num(r.safe_ms, "{:.1f}"), num(r.max_safe_ms, "{:.1f}"),
                       r.peak_force_N, r.peak_speed_degps, num(r.min_tension_N, "{:.2f}"), r.limits_exceeded, r.physics_forbids,
                       r.log_complete ? 1 : 0, r.outcome_met() ? 1 : 0, r.lost, r.late, r.corrupt, r.duplicate, r.stale, r.foreign,
                       r.unauthenticated, r.accepted);
  }
  std::size_t met = 0, complete = 0;
  for (const LinkFaultRow& r : rows) met += r.outcome_met(), complete += r.log_complete;
  std::ofstream md(dir / "faults_link.md");
  md << "# The link's faults: E1 over UDP\n\n";
  md << fmt::format("Scenario `{}`, case `{}`, over real UDP (loopback) to `peha mfb-emulator` in its own process, neither side SCHED_FIFO, "
                    "the watchdogs as configured, the supervisor's plausibility stage on. Each run lasts {:g} s; a fault with a moment is "
                    "injected at {:g} s (after the start-up vent, tare and refill), the random ones run the whole time (emulator "
                    "--fault-seed {}). Force, speed and tension are the host's sensors (load cells, velocity estimate) from the injection "
                    "(or the end of the tare's slack) on: over UDP there is no plant truth.\n\n",
                    scenario_name, options.case_name.empty() ? "(first)" : options.case_name, options.fault_at_s + options.after_fault_s,
                    options.fault_at_s, options.seed);
  md << fmt::format("Rows: {}; designed outcome met (a fault where one is designed, none where the link rides it out; no limit exceeded "
                    "unless physics forbids): {}; log complete: {}.\n\n", rows.size(), met, complete);
  md << "| fault | injects | expected | detected by | ms | cycles | safe ms | peak load cell N | peak speed deg/s | min load cell N | limits exceeded "
        "| log complete | outcome | lost | late | corrupt | duplicate | stale | foreign |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const LinkFaultRow& r : rows) {
    const std::string expected = !r.expect_detection ? "ride out"
                                 : fmt::format("fault{}{}", r.expect_by.empty() ? "" : ": " + r.expect_by,
                                               std::isfinite(r.max_safe_ms) ? fmt::format(", safe <= {:.0f} ms", r.max_safe_ms) : "");
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {:.0f} | {:.1f} | {} | {}{} | {} | {} | {} | {} | {} | {} | {} | {} |\n", r.fault, r.injects,
                      expected, r.detected ? r.by : (r.expect_detection ? "**not detected**" : "-"),
                      num(r.detection_ms, "{:.1f}"), num(r.detection_cycles, "{:.0f}"), num(r.safe_ms, "{:.1f}"), r.peak_force_N, r.peak_speed_degps,
                      num(r.min_tension_N, "{:.1f}"), r.limits_exceeded, r.physics_forbids.empty() ? "" : " (physics forbids)",
                      r.log_complete ? "yes" : "**no**", r.outcome_met() ? "met" : "**missed**", r.lost, r.late, r.corrupt, r.duplicate, r.stale, r.foreign);
  }
}

}  // namespace peha::experiments
