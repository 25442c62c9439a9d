#include "peha/runtime/realtime_harness.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <poll.h>
#include <unistd.h>

namespace peha::runtime {
RealtimeHarness::RealtimeHarness(io::Backend& backend, const SupervisorParams& supervision, const RealtimeRunOptions& options,
                                 double period_s, double duration_s, std::string label, const std::filesystem::path& log_file,
                                 const std::vector<std::string>& columns, const std::vector<std::string>& comments)
    : backend_(backend),
      supervisor_(backend, supervision),
      options_(options),
      period_s_(period_s),
      duration_s_(duration_s),
      label_(std::move(label)),
      log_(log_file, columns, comments, 1u << 14, static_cast<std::size_t>(std::llround(5.0 / period_s))),
      sink_(*this),
      clock_(period_s) {
  result_.log_file = log_file.string();
  result_.timing.overrun_events.reserve(kOverrunEventsListed);
  if (options.telemetry.destination) telemetry_ = std::make_unique<LogTelemetry>(options.telemetry, columns, telemetry_extras());
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
          for (ssize_t i = 0; i < n; ++i) {
            if (buf[i] == 'r' || buf[i] == 'R') supervisor_.request_recovery();
          }
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
  // Ctrl-C / SIGTERM during the run: the loop ends at the next cycle and winds down normally
  // (outputs disabled, log flushed, statistics printed) instead of dying mid-cycle.
  interrupt_.emplace();
  result_.realtime = configure_realtime_thread(options_.realtime);
  supervisor_.on_fault = [this](const char* why) { log_.request_fault_dump(why); };
  supervisor_.start(0.0);  // last in set-up: the handshake's answer is followed by the enable edge within a period
  clock_.set_spin_ns(options_.realtime.wake_spin_ns);
  clock_.start();
  CycleHooks hooks;
  hooks.wait = [this] {
    // The thread's counters from the first cycle on (what the experiment sets up before its
    // first cycle, e.g. memory mlockall populates, is not the loop's).
    if (cycle_start_ns_ == 0) counters_at_start_ = thread_counters();
    const double late_s = clock_.wait_next();
    const std::int64_t now = PeriodicClock::now_ns();
    LoopTiming& t = result_.timing;
    if (clock_.last_skipped() > 0 && cycle_start_ns_ != 0 && t.overrun_events.size() < t.overrun_events.capacity()) {
      t.overrun_events.push_back({static_cast<double>(cycle_start_ns_ - clock_.start_ns()) * 1e-9, clock_.last_skipped(), wake_late_s_,
                                  static_cast<double>(clock_.last_call_ns() - cycle_start_ns_) * 1e-9, backend_.status().last_rtt_s});
    }
    t.wake.add(late_s);
    wake_late_s_ = late_s;
    if (last_wake_ns_) t.period.add(static_cast<double>(now - last_wake_ns_) * 1e-9);
    last_wake_ns_ = cycle_start_ns_ = now;
  };
  hooks.supervisor = &supervisor_;
  hooks.after = [this](const io::SensorState& state, const io::Command& sent) { return after(state, sent); };
  // The loop's counters end with its last cycle: the experiment's analysis after it (tens of MB of
  // results, each new page a minor fault under mlockall) is not the loop's.
  hooks.done = [this] { counters_at_end_ = thread_counters(); };
  return hooks;
}

void RealtimeHarness::Sink::push_row(std::span<const double> row) noexcept {
  harness_.log_.push(row);
  if (!harness_.telemetry_) return;
  // The row's cycle has been supervised and written: its round trip and state are this cycle's.
  const double extras[] = {harness_.backend_.status().last_rtt_s * 1e6,
                           static_cast<double>(static_cast<int>(harness_.supervisor_.lifecycle().state()))};
  harness_.telemetry_->publish(row, extras);
}

bool RealtimeHarness::after(const io::SensorState&, const io::Command&) noexcept {
  const double t = clock_.deadline_s();
  const io::BackendStatus status = backend_.status();
  if (status.rtt_samples != rtt_samples_) {  // the round trip of the command this sample answers
    rtt_samples_ = status.rtt_samples;
    result_.timing.rtt.add(status.last_rtt_s);
  }
  const LifecycleState lifecycle = supervisor_.lifecycle().state();
  progress_t_.store(t, std::memory_order_relaxed);
  progress_state_.store(static_cast<int>(lifecycle), std::memory_order_relaxed);
  result_.timing.compute.add(static_cast<double>(PeriodicClock::now_ns() - cycle_start_ns_) * 1e-9);
  if (interrupt_requested()) {
    interrupted_ = true;
    return false;  // the experiment's loop ends here; finish() winds down
  }
  return true;
}

void RealtimeHarness::finish(RealtimeRunResult& res) {
  // Wind down: outputs disabled (a board vents in its controlled way; the disabled commands tell it
  // so), then close.
  supervisor_.finish(clock_.deadline_s(), interrupted_ ? "interrupted (Ctrl-C)" : "experiment finished");
  io::Command idle;
  idle.joint_count = static_cast<int>(backend_.info().joint_names.size());
  for (int i = 0; i < 5; ++i) backend_.write(idle);
  interrupt_.reset();
  const ThreadCounters end = counters_at_end_ ? *counters_at_end_ : thread_counters();
  result_.timing.minor_faults = end.minor_faults - counters_at_start_.minor_faults;
  result_.timing.major_faults = end.major_faults - counters_at_start_.major_faults;
  result_.timing.involuntary_switches = end.involuntary_switches - counters_at_start_.involuntary_switches;
  make_thread_non_realtime();
  done_ = true;
  if (progress_.joinable()) progress_.join();
  if (console_.joinable()) console_.join();
  result_.timing.cycles = clock_.cycles();
  result_.timing.overruns = clock_.overruns();
  result_.timing.deadline_misses = clock_.missed_deadlines();
  result_.timing.max_burst = clock_.max_skipped();
  result_.timing.lost_packets = supervisor_.cycles_without_sample();
  result_.faults = supervisor_.faults();
  result_.recoveries = supervisor_.recoveries();
  log_.close();
  result_.logged_rows = log_.written_rows();
  result_.dropped_rows = log_.dropped_rows();
  result_.fault_dumps = log_.fault_dumps();
  if (telemetry_) {
    telemetry_->close();
    result_.telemetry_datagrams = telemetry_->telemetry().sent_datagrams();
  }
  const Lifecycle& lifecycle = supervisor_.lifecycle();
  for (std::size_t i = 0; i < lifecycle.history_size(); ++i) {
    const LifecycleEvent& e = lifecycle.history(i);
    result_.lifecycle.push_back(fmt::format("{:8.3f} s  {} -> {} ({})", e.t_s, to_string(e.from), to_string(e.to), e.reason));
  }
  res = std::move(result_);
}

}  // namespace peha::runtime
