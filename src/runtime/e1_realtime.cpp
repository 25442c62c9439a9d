#include "peha/runtime/e1_realtime.hpp"

#include "peha/runtime/async_log.hpp"
#include "peha/runtime/telemetry.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <poll.h>
#include <thread>
#include <unistd.h>

namespace peha::runtime {
namespace {

/// Rows of the loop go to the writer thread's ring.
class AsyncSink final : public RowSink {
 public:
  explicit AsyncSink(AsyncCsvLog& log) : log_(log) {}
  void push_row(std::span<const double> row) noexcept override { log_.push(row); }

 private:
  AsyncCsvLog& log_;
};

/// The operator's terminal: `r` + Enter asks for a recovery. Polls stdin (only if it is a terminal)
/// off the real-time thread.
class OperatorConsole {
 public:
  explicit OperatorConsole(std::atomic<bool>& recover) : recover_(recover) {
    if (::isatty(STDIN_FILENO)) thread_ = std::thread([this] { loop(); });
  }
  ~OperatorConsole() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  void loop() {
    while (!stop_) {
      pollfd p{STDIN_FILENO, POLLIN, 0};
      if (::poll(&p, 1, 100) > 0 && (p.revents & POLLIN)) {
        char buf[64];
        const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
        if (n <= 0) return;
        for (ssize_t i = 0; i < n; ++i) {
          if (buf[i] == 'r' || buf[i] == 'R') recover_ = true;
        }
      }
    }
  }
  std::atomic<bool>& recover_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace

RealtimeRunResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const RealtimeRunOptions& options) {
  if (!scenario.link) throw std::runtime_error("the scenario has no mfb: section (channel map, watchdogs): see docs/runtime.md");
  const LinkConfig& link = *scenario.link;
  const std::vector<std::string> joints = {"joint"};
  mfb::UdpBackendParams bp;
  bp.board = options.board;
  bp.period_s = scenario.period_s;
  bp.receive_timeout_s = link.receive_timeout_s;
  bp.joint_names = joints;
  mfb::UdpBackend backend(bp, mfb::read_channel_map(config::Document::load_file(link.channel_map), joints));

  RealtimeRunResult res;
  Lifecycle lc;
  backend.connect();
  lc.apply(Transition::kConfigure, 0.0, "session open: the board answered");

  const auto steps = static_cast<std::size_t>(std::llround(scenario.duration_s / scenario.period_s));
  res.log_file = (options.dir / fmt::format("e1_{}.csv", c.name)).string();
  AsyncCsvLog log(res.log_file, e1_log_columns(),
                  {fmt::format("case: {} (payload {} kg) on the MFB at udp://{}", c.name, c.payload_kg, options.board.to_string()),
                   fmt::format("session {:08x}; plant_* and finger columns are NaN: the host sees only the board's sensors",
                               backend.session_id())},
                  1u << 14, static_cast<std::size_t>(std::llround(5.0 / scenario.period_s)));
  AsyncSink sink(log);
  std::unique_ptr<Telemetry> telemetry;
  const std::vector<std::string> signals = {"angle_deg", "f_agonist_N", "f_antagonist_N",
                                            "p_agonist_cmd_MPa", "p_antagonist_cmd_MPa", "motor_Nm", "rtt_us", "state"};
  if (options.telemetry) {
    const io::UdpEndpoint& e = *options.telemetry;
    const std::string host = e.to_string().substr(0, e.to_string().rfind(':'));
    telemetry = std::make_unique<Telemetry>(host, e.port, options.telemetry_rate_Hz, "peha", signals);
  }
  std::atomic<bool> operator_recover{false};
  OperatorConsole console(operator_recover);
  std::atomic<double> progress_t{0.0};
  std::atomic<int> progress_state{0};
  std::atomic<bool> done{false};
  std::thread progress;
  if (!options.quiet) {
    progress = std::thread([&] {
      make_thread_non_realtime();
      while (!done) {
        for (int i = 0; i < 10 && !done; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (done) break;
        std::fprintf(stderr, "  %s: t = %5.1f / %.0f s, %s\n", c.name.c_str(), progress_t.load(), scenario.duration_s,
                     to_string(static_cast<LifecycleState>(progress_state.load())));
      }
    });
  }

  // From here on this thread is the control loop.
  res.realtime = configure_realtime_thread(options.realtime);
  PeriodicClock clock(scenario.period_s);
  const auto host_watchdog_ns = static_cast<std::int64_t>(link.host_watchdog_s * 1e9);
  std::int64_t cycle_start = 0, last_wake = 0;
  double fault_t = -1.0, ramp_t = -1.0;
  io::Command ramp_from;
  std::array<double, 8> tele{};

  backend.set_enable(true);
  lc.apply(Transition::kActivate, 0.0, "enable edge sent");
  CycleHooks hooks;
  hooks.wait = [&] {
    clock.wait_next();
    const std::int64_t now = PeriodicClock::now_ns();
    if (last_wake) res.timing.period.add(static_cast<double>(now - last_wake) * 1e-9);
    last_wake = cycle_start = now;
  };
  hooks.after = [&](const io::SensorState& state, io::Command& cmd, std::uint32_t) {
    const double t = clock.deadline_s();
    if (backend.last_read_was_reply()) res.timing.rtt.add(backend.last_rtt_s());  // the previous cycle's command
    const std::int64_t now = PeriodicClock::now_ns();
    const bool silent = now - backend.last_sample_ns() > host_watchdog_ns;
    const std::uint8_t status = backend.board_status();
    switch (lc.state()) {
      case LifecycleState::kActive:
        if (silent || (status & (mfb::kStatusWatchdogTripped | mfb::kStatusEstop))) {
          const char* why = silent ? "board silent for longer than host_watchdog_ms"
                            : (status & mfb::kStatusEstop) ? "board reports its e-stop input"
                                                           : "board watchdog tripped";
          lc.apply(Transition::kFault, t, why);
          log.request_fault_dump(why);
          backend.set_enable(false);
          ++res.faults;
          fault_t = t;
        }
        break;
      case LifecycleState::kFault: {
        const bool asked = operator_recover.exchange(false) || (options.recover_after_s >= 0 && t - fault_t >= options.recover_after_s);
        if (asked && !silent && !(status & mfb::kStatusEstop) && backend.board_saw_disable()) {
          lc.apply(Transition::kRecover, t, "operator's command");
          backend.set_enable(true);  // the enable edge re-arms the board
          ramp_t = t;
          ramp_from = cmd;
          for (int j = 0; j < cmd.joint_count; ++j) {  // from what the muscles hold now, motor off
            auto& r = ramp_from.joints[static_cast<std::size_t>(j)];
            r.agonist_pressure_Pa = state.joints[static_cast<std::size_t>(j)].agonist_pressure_Pa;
            r.antagonist_pressure_Pa = state.joints[static_cast<std::size_t>(j)].antagonist_pressure_Pa;
            r.motor_torque_Nm = 0.0;
          }
        }
        break;
      }
      case LifecycleState::kRecovering:
        if (!(status & mfb::kStatusOutputsSafe)) {
          lc.apply(Transition::kRecovered, t, "board re-armed");
          lc.apply(Transition::kActivate, t, "ramping back to the controller's command");
          ++res.recoveries;
        } else if (t - ramp_t > 0.5) {
          lc.apply(Transition::kFault, t, "board did not re-arm within 0.5 s");
          backend.set_enable(false);
          fault_t = t;
        }
        break;
      default:
        break;
    }
    // A ramp after a recovery: from what the muscles held to the controller's command, no jump.
    if (ramp_t >= 0.0 && lc.state() != LifecycleState::kFault) {
      const double s = link.recovery_ramp_s > 0 ? std::clamp((t - ramp_t) / link.recovery_ramp_s, 0.0, 1.0) : 1.0;
      for (int j = 0; j < cmd.joint_count; ++j) {
        auto& o = cmd.joints[static_cast<std::size_t>(j)];
        const auto& f = ramp_from.joints[static_cast<std::size_t>(j)];
        o.agonist_pressure_Pa = f.agonist_pressure_Pa + s * (o.agonist_pressure_Pa - f.agonist_pressure_Pa);
        o.antagonist_pressure_Pa = f.antagonist_pressure_Pa + s * (o.antagonist_pressure_Pa - f.antagonist_pressure_Pa);
        o.motor_torque_Nm = f.motor_torque_Nm + s * (o.motor_torque_Nm - f.motor_torque_Nm);
      }
      if (s >= 1.0) ramp_t = -1.0;
    }
    if (telemetry) {
      const auto& s = state.joints[0];
      const auto& o = cmd.joints[0];
      tele = {s.angle_rad * 180.0 / 3.141592653589793, s.agonist_force_N, s.antagonist_force_N,
              o.agonist_pressure_Pa * 1e-6, o.antagonist_pressure_Pa * 1e-6, o.motor_torque_Nm,
              backend.last_rtt_s() * 1e6, static_cast<double>(static_cast<int>(lc.state()))};
      telemetry->publish(t, tele);
    }
    progress_t.store(t, std::memory_order_relaxed);
    progress_state.store(static_cast<int>(lc.state()), std::memory_order_relaxed);
    res.timing.compute.add(static_cast<double>(PeriodicClock::now_ns() - cycle_start) * 1e-9);
    return true;
  };
  clock.start();
  res.e1 = run_e1_on(scenario, c, backend, nullptr, &sink, hooks);

  // Wind down: outputs disabled (the board vents in its controlled way), then close.
  backend.set_enable(false);
  io::Command idle;
  idle.joint_count = 1;
  for (int i = 0; i < 5; ++i) backend.write(idle);
  lc.apply(Transition::kDeactivate, clock.deadline_s(), "experiment finished");
  lc.apply(Transition::kShutdown, clock.deadline_s(), "run ended");
  make_thread_non_realtime();
  done = true;
  if (progress.joinable()) progress.join();
  res.timing.cycles = clock.cycles();
  res.timing.overruns = clock.overruns();
  res.timing.deadline_misses = clock.missed_deadlines();
  res.timing.lost_packets = backend.stats().replies_missing;
  res.link = backend.stats();
  log.close();
  res.logged_rows = log.written_rows();
  res.dropped_rows = log.dropped_rows();
  res.fault_dumps = log.fault_dumps();
  if (telemetry) {
    telemetry->close();
    res.telemetry_datagrams = telemetry->sent_datagrams();
  }
  for (std::size_t i = 0; i < lc.history_size(); ++i) {
    const LifecycleEvent& e = lc.history(i);
    res.lifecycle.push_back(fmt::format("{:8.3f} s  {} -> {} ({})", e.t_s, to_string(e.from), to_string(e.to), e.reason));
  }
  (void)steps;
  return res;
}

}  // namespace peha::runtime
