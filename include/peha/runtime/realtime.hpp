#pragma once
/// \file
/// Real-time set-up of the control thread and its periodic clock (1 kHz loop with absolute
/// deadlines; SCHED_FIFO, locked memory and a pinned CPU when permitted, a loud warning when not).
///
/// `configure_realtime_thread` asks the kernel for each setting separately. A refusal is not an
/// error (a developer laptop runs the loop too): it becomes a warning in the report that names the
/// errno and the fix, and the whole list is logged in a banner with spdlog::warn. Nothing is ever
/// refused silently. Only nonsensical options (a priority outside 1..99) throw.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace peha::runtime {

struct RealtimeOptions {
  int fifo_priority = 80;      ///< SCHED_FIFO priority, 1..99 (99 highest); 0 = keep SCHED_OTHER
  int cpu = -1;                ///< CPU to pin the calling thread to; -1 = don't pin
  bool lock_memory = true;     ///< mlockall(MCL_CURRENT | MCL_FUTURE): process-wide, not per thread
  std::size_t prefault_stack_bytes = 256 * 1024;  ///< stack touched now so the loop never faults it in; 0 = skip
  /// prctl(PR_SET_TIMERSLACK) of the calling thread in ns; 0 = leave it (the default 50 us for
  /// SCHED_OTHER). The kernel ignores the slack of SCHED_FIFO threads, so it matters only where
  /// SCHED_FIFO was refused (or not asked for).
  unsigned long timer_slack_ns = 0;
  /// The loop's PeriodicClock sleeps until this long before each deadline and polls the clock for
  /// the rest (PeriodicClock::set_spin_ns); 0 = clock_nanosleep all the way.
  std::int64_t wake_spin_ns = 0;
};

/// What was granted. `warnings` holds one line per refusal (errno name, consequence and fix).
struct RealtimeReport {
  bool fifo = false;           ///< the thread runs SCHED_FIFO at `priority`
  int priority = 0;            ///< granted SCHED_FIFO priority (may be below the request; see warnings)
  bool memory_locked = false;  ///< all current and future pages of the process are locked in RAM
  bool pinned = false;         ///< the thread runs on CPU `cpu` only
  int cpu = -1;
  std::size_t stack_prefaulted_bytes = 0;
  bool preempt_rt_kernel = false;  ///< the running kernel is PREEMPT_RT (bounded wake-up latency)
  std::vector<std::string> warnings;
  /// One line: what was asked, what was granted, how many warnings.
  std::string summary() const;
};

/// Applies `options` to the calling thread (and, for memory locking, the whole process). Logs the
/// outcome: spdlog::info if everything asked for was granted, else a spdlog::warn banner with every
/// warning. Throws std::invalid_argument only for invalid options, never for a refusal.
RealtimeReport configure_realtime_thread(const RealtimeOptions& options);

/// Drops the calling thread back to SCHED_OTHER and lets it run on every CPU the process may use.
/// The helper threads (CSV writer, telemetry sender) call it first: threads inherit the policy and
/// affinity of their creator, and they must never compete with the loop for its CPU. Best effort.
void make_thread_non_realtime() noexcept;

/// The calling thread's page faults and involuntary context switches so far (getrusage
/// RUSAGE_THREAD); differences of two readings bracket a loop.
struct ThreadCounters {
  std::uint64_t minor_faults = 0, major_faults = 0, involuntary_switches = 0;
};
ThreadCounters thread_counters() noexcept;

/// A periodic schedule of absolute deadlines t0 + k * period on CLOCK_MONOTONIC.
///
/// Overrun policy: if, when `wait_next` is called, the next deadline has already passed (the cycle's
/// compute overran), the clock does not run the late cycles back to back. It skips every deadline
/// that has passed, counts them in `missed_deadlines`, and sleeps until the first deadline still in
/// the future. Cycles therefore always start on the grid and never burst; a cycle's nominal time is
/// `deadline_s()` (which includes the skipped deadlines), not `cycles() * period`.
class PeriodicClock {
 public:
  /// `period_s` > 0 (rounded to whole nanoseconds); throws std::invalid_argument otherwise.
  explicit PeriodicClock(double period_s);

  /// t0 = now; the first deadline is t0 + period. Resets the counters.
  void start() noexcept;

  /// Sleeps until the next deadline (clock_nanosleep with TIMER_ABSTIME, so the sleep does not
  /// accumulate the compute time's jitter). Returns how late it woke, in s (>= 0 up to clock noise).
  double wait_next() noexcept;

  double period_s() const noexcept { return static_cast<double>(period_ns_) * 1e-9; }
  std::uint64_t cycles() const noexcept { return cycles_; }                    ///< wait_next calls since start
  std::uint64_t missed_deadlines() const noexcept { return missed_; }          ///< deadlines skipped
  std::uint64_t overruns() const noexcept { return overruns_; }                ///< calls that found their deadline passed
  /// Deadline of the current cycle (the one wait_next last woke for) relative to t0, in s.
  double deadline_s() const noexcept { return static_cast<double>(deadline_ns_ - t0_ns_) * 1e-9; }
  std::int64_t deadline_ns() const noexcept { return deadline_ns_; }  ///< deadline of the current cycle, CLOCK_MONOTONIC ns
  std::int64_t start_ns() const noexcept { return t0_ns_; }  ///< t0 on CLOCK_MONOTONIC, ns
  /// Deadlines the last wait_next call skipped (0: the cycle ended in time), and the largest such
  /// burst since start: one stall of 20 periods is one overrun of 20 missed deadlines.
  std::uint64_t last_skipped() const noexcept { return last_skipped_; }
  std::uint64_t max_skipped() const noexcept { return max_skipped_; }
  /// When the last wait_next was called (the end of the previous cycle's work), CLOCK_MONOTONIC ns.
  std::int64_t last_call_ns() const noexcept { return last_call_ns_; }

  /// Sleep until `spin_ns` before each deadline, then poll the clock up to the deadline (0 = sleep
  /// all the way, the default). Trades CPU time for the timer's wake-up latency.
  void set_spin_ns(std::int64_t spin_ns) noexcept { spin_ns_ = spin_ns > 0 ? spin_ns : 0; }

  /// CLOCK_MONOTONIC now, in ns.
  static std::int64_t now_ns() noexcept;

 private:
  std::int64_t period_ns_;
  std::int64_t t0_ns_ = 0;
  std::int64_t deadline_ns_ = 0;  ///< deadline of the current cycle
  std::uint64_t cycles_ = 0;
  std::uint64_t missed_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint64_t last_skipped_ = 0;
  std::uint64_t max_skipped_ = 0;
  std::int64_t last_call_ns_ = 0;
  std::int64_t spin_ns_ = 0;
};

}  // namespace peha::runtime
