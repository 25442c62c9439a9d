#include "peha/runtime/realtime_harness.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <poll.h>
#include <unistd.h>

namespace peha::runtime {
namespace {

// Ctrl-C / SIGTERM during a run: the loop ends at the next cycle and winds down normally (outputs
// disabled, log flushed, statistics printed) instead of dying mid-cycle.
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted = true; }

}  // namespace

RealtimeHarness::RealtimeHarness(mfb::UdpBackend& backend, const mfb::LinkConfig& link, const RealtimeRunOptions& options, double period_s,
                                 double duration_s, std::string label, const std::filesystem::path& log_file,
                                 const std::vector<std::string>& columns, const std::vector<std::string>& comments)
    : backend_(backend),
      link_(link),
      options_(options),
      period_s_(period_s),
      duration_s_(duration_s),
      label_(std::move(label)),
      log_(log_file, columns, comments, 1u << 14, static_cast<std::size_t>(std::llround(5.0 / period_s))),
      sink_(log_),
      clock_(period_s) {
  result_.log_file = log_file.string();
  if (options.telemetry) {
    std::vector<std::string> signals;
    const auto& names = backend.info().joint_names;
    for (const std::string& j : names) {
      const std::string p = names.size() > 1 ? j + "." : std::string();
      for (const char* s : {"angle_deg", "f_agonist_N", "f_antagonist_N", "p_agonist_cmd_MPa", "p_antagonist_cmd_MPa", "motor_Nm"}) {
        signals.push_back(p + s);
      }
    }
    signals.push_back("rtt_us");
    signals.push_back("lifecycle_state");
    telemetry_values_.resize(signals.size());
    const std::string dest = options.telemetry->to_string();
    telemetry_ = std::make_unique<Telemetry>(dest.substr(0, dest.rfind(':')), options.telemetry->port, options.telemetry_rate_Hz,
                                             "peha", signals);
  }
  // The operator's terminal: 'r' + Enter asks for a recovery (polled off the real-time thread).
  if (::isatty(STDIN_FILENO)) {
    console_ = std::thread([this] {
      make_thread_non_realtime();
      while (!done_) {
        pollfd p{STDIN_FILENO, POLLIN, 0};
        if (::poll(&p, 1, 100) > 0 && (p.revents & POLLIN)) {
          char buf[64];
          const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
          if (n <= 0) return;
          for (ssize_t i = 0; i < n; ++i) operator_recover_ = operator_recover_ || buf[i] == 'r' || buf[i] == 'R';
        }
      }
    });
  }
  if (!options.quiet) {
    progress_ = std::thread([this] {
      make_thread_non_realtime();
      while (!done_) {
        for (int i = 0; i < 10 && !done_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (done_) break;
        std::fprintf(stderr, "  %s: t = %5.1f / %.0f s, %s\n", label_.c_str(), progress_t_.load(), duration_s_,
                     to_string(static_cast<LifecycleState>(progress_state_.load())));
      }
    });
  }
}

RealtimeHarness::~RealtimeHarness() {
  done_ = true;
  if (console_.joinable()) console_.join();
  if (progress_.joinable()) progress_.join();
}

CycleHooks RealtimeHarness::start() {
  g_interrupted = false;
  previous_sigint_ = std::signal(SIGINT, on_interrupt);
  previous_sigterm_ = std::signal(SIGTERM, on_interrupt);
  result_.realtime = configure_realtime_thread(options_.realtime);
  // The handshake comes last, right before the enable edge: from the board's first answer until
  // an enabled command it holds its safe outputs and its plant vents (tens of ms of set-up here -
  // log, threads, mlockall of the whole process - would start the run from a sagging arm, and
  // more than the board's watchdog would trip it). The reply also carries the board's status as of
  // now: a trip latched earlier is acknowledged by the handshake's disabled command.
  backend_.connect();
  lifecycle_.apply(Transition::kConfigure, 0.0, "session open: the board answered");
  backend_.set_enable(true);
  lifecycle_.apply(Transition::kActivate, 0.0, "enable edge sent");
  clock_.start();
  CycleHooks hooks;
  hooks.wait = [this] {
    clock_.wait_next();
    const std::int64_t now = PeriodicClock::now_ns();
    if (last_wake_ns_) result_.timing.period.add(static_cast<double>(now - last_wake_ns_) * 1e-9);
    last_wake_ns_ = cycle_start_ns_ = now;
  };
  hooks.after = [this](const io::SensorState& state, io::Command& command, std::uint32_t) { return after(state, command); };
  return hooks;
}

bool RealtimeHarness::after(const io::SensorState& state, io::Command& cmd) noexcept {
  const double t = clock_.deadline_s();
  double rtt_s = 0.0;
  if (backend_.take_new_rtt(rtt_s)) result_.timing.rtt.add(rtt_s);  // the command this sample answers
  const std::int64_t sample_ns = backend_.last_sample_ns();
  cycles_without_sample_ = sample_ns != seen_sample_ns_ ? 0 : cycles_without_sample_ + 1;
  seen_sample_ns_ = sample_ns;
  const bool silent = cycles_without_sample_ >= kSilentCycles &&
                      PeriodicClock::now_ns() - sample_ns > static_cast<std::int64_t>(link_.host_watchdog_s * 1e9);
  const std::uint8_t status = backend_.board_status();
  const bool estop = (status & mfb::kStatusEstop) || backend_.estop_input();
  switch (lifecycle_.state()) {
    case LifecycleState::kActive:
      if (silent || estop || (status & mfb::kStatusWatchdogTripped)) {
        const char* why = silent ? "board silent for longer than host_watchdog_ms"
                          : estop ? "board reports its e-stop input"
                                  : "board watchdog tripped";
        lifecycle_.apply(Transition::kFault, t, why);
        log_.request_fault_dump(why);
        backend_.set_enable(false);
        ++result_.faults;
        fault_t_ = t;
      }
      break;
    case LifecycleState::kFault: {
      const bool asked = operator_recover_.exchange(false) || (options_.recover_after_s >= 0 && t - fault_t_ >= options_.recover_after_s);
      if (asked && !silent && !estop && backend_.board_saw_disable()) {
        lifecycle_.apply(Transition::kRecover, t, "operator's command");
        backend_.set_enable(true);  // the enable edge re-arms the board
        ramp_t_ = t;
        ramp_from_ = cmd;
        for (int j = 0; j < cmd.joint_count; ++j) {  // from what the muscles hold now, motor off
          const auto i = static_cast<std::size_t>(j);
          ramp_from_.joints[i].agonist_pressure_Pa = state.joints[i].agonist_pressure_Pa;
          ramp_from_.joints[i].antagonist_pressure_Pa = state.joints[i].antagonist_pressure_Pa;
          ramp_from_.joints[i].motor_torque_Nm = 0.0;
        }
      }
      break;
    }
    case LifecycleState::kRecovering:
      if (!(status & mfb::kStatusOutputsSafe)) {
        lifecycle_.apply(Transition::kRecovered, t, "board re-armed");
        lifecycle_.apply(Transition::kActivate, t, "ramping back to the controller's command");
        ++result_.recoveries;
      } else if (t - ramp_t_ > 0.5) {
        lifecycle_.apply(Transition::kFault, t, "board did not re-arm within 0.5 s");
        backend_.set_enable(false);
        fault_t_ = t;
      }
      break;
    default:
      break;
  }
  // After a recovery: from what the muscles held to the controller's command, no jump.
  if (ramp_t_ >= 0.0 && lifecycle_.state() != LifecycleState::kFault) {
    const double s = link_.recovery_ramp_s > 0 ? std::clamp((t - ramp_t_) / link_.recovery_ramp_s, 0.0, 1.0) : 1.0;
    for (int j = 0; j < cmd.joint_count; ++j) {
      auto& o = cmd.joints[static_cast<std::size_t>(j)];
      const auto& f = ramp_from_.joints[static_cast<std::size_t>(j)];
      o.agonist_pressure_Pa = f.agonist_pressure_Pa + s * (o.agonist_pressure_Pa - f.agonist_pressure_Pa);
      o.antagonist_pressure_Pa = f.antagonist_pressure_Pa + s * (o.antagonist_pressure_Pa - f.antagonist_pressure_Pa);
      o.motor_torque_Nm = f.motor_torque_Nm + s * (o.motor_torque_Nm - f.motor_torque_Nm);
    }
    if (s >= 1.0) ramp_t_ = -1.0;
  }
  if (telemetry_) {
    std::size_t k = 0;
    for (int j = 0; j < state.joint_count && k + 6 <= telemetry_values_.size(); ++j) {
      const auto& s = state.joints[static_cast<std::size_t>(j)];
      const auto& o = cmd.joints[static_cast<std::size_t>(j)];
      for (double v : {s.angle_rad * 180.0 / std::numbers::pi, s.agonist_force_N, s.antagonist_force_N, o.agonist_pressure_Pa * 1e-6,
                       o.antagonist_pressure_Pa * 1e-6, o.motor_torque_Nm}) {
        telemetry_values_[k++] = v;
      }
    }
    telemetry_values_[telemetry_values_.size() - 2] = backend_.last_rtt_s() * 1e6;
    telemetry_values_.back() = static_cast<double>(static_cast<int>(lifecycle_.state()));
    telemetry_->publish(t, telemetry_values_);
  }
  progress_t_.store(t, std::memory_order_relaxed);
  progress_state_.store(static_cast<int>(lifecycle_.state()), std::memory_order_relaxed);
  result_.timing.compute.add(static_cast<double>(PeriodicClock::now_ns() - cycle_start_ns_) * 1e-9);
  if (g_interrupted.load(std::memory_order_relaxed)) {
    interrupted_ = true;
    return false;  // the experiment's loop ends here; finish() winds down
  }
  return true;
}

void RealtimeHarness::finish(RealtimeRunResult& res) {
  // Wind down: outputs disabled (the board vents in its controlled way), then close.
  backend_.set_enable(false);
  io::Command idle;
  idle.joint_count = static_cast<int>(backend_.info().joint_names.size());
  for (int i = 0; i < 5; ++i) backend_.write(idle);
  lifecycle_.apply(Transition::kDeactivate, clock_.deadline_s(), interrupted_ ? "interrupted (Ctrl-C)" : "experiment finished");
  std::signal(SIGINT, previous_sigint_);
  std::signal(SIGTERM, previous_sigterm_);
  lifecycle_.apply(Transition::kShutdown, clock_.deadline_s(), "run ended");
  make_thread_non_realtime();
  done_ = true;
  if (progress_.joinable()) progress_.join();
  if (console_.joinable()) console_.join();
  result_.timing.cycles = clock_.cycles();
  result_.timing.overruns = clock_.overruns();
  result_.timing.deadline_misses = clock_.missed_deadlines();
  result_.timing.lost_packets = backend_.stats().replies_missing;
  result_.link = backend_.stats();
  log_.close();
  result_.logged_rows = log_.written_rows();
  result_.dropped_rows = log_.dropped_rows();
  result_.fault_dumps = log_.fault_dumps();
  if (telemetry_) {
    telemetry_->close();
    result_.telemetry_datagrams = telemetry_->sent_datagrams();
  }
  for (std::size_t i = 0; i < lifecycle_.history_size(); ++i) {
    const LifecycleEvent& e = lifecycle_.history(i);
    result_.lifecycle.push_back(fmt::format("{:8.3f} s  {} -> {} ({})", e.t_s, to_string(e.from), to_string(e.to), e.reason));
  }
  res = std::move(result_);
}

}  // namespace peha::runtime
