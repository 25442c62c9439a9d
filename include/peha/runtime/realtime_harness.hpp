#pragma once
/// \file
/// What every experiment needs to run in real time on hardware (the multifunction board), around
/// the one loop (runtime::run_cycles): the absolute-deadline clock, the real-time thread set-up with
/// its warnings, the run's supervisor (runtime::Supervisor: lifecycle, fault detection, the
/// operator's recovery - `r` + Enter on the terminal or `recover_after_s` - and the ramp back), the
/// writer-thread CSV log with a dump of the last 5 s on every fault, optional PlotJuggler
/// telemetry of the log's columns (log_telemetry.hpp), a progress line and the timing statistics. It takes any io::Backend. The experiment's
/// loop gets `hooks()` (pacing, supervisor, timing) and `sink()` (its log rows).

#include "peha/io/udp_socket.hpp"
#include "peha/runtime/async_log.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/runtime/interrupt.hpp"
#include "peha/runtime/lifecycle.hpp"
#include "peha/runtime/log_telemetry.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/runtime/supervisor.hpp"
#include "peha/runtime/telemetry.hpp"
#include "peha/runtime/timing_stats.hpp"

#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace peha::runtime {

struct RealtimeRunOptions {
  RealtimeOptions realtime;                    ///< SCHED_FIFO priority, CPU, mlockall
  /// Live telemetry of the log's columns (and the harness's telemetry_extras), if a destination is set.
  TelemetryOptions telemetry;
  double recover_after_s = -1;                 ///< unattended operator: recover this long after a fault (< 0: only 'r' on stdin)
  std::filesystem::path dir;                   ///< run directory: log, fault dumps, timing
  bool quiet = false;                          ///< no progress line
};

/// What the harness measured (the experiment's own figures come with its runner).
struct RealtimeRunResult {
  LoopTiming timing;
  RealtimeReport realtime;
  std::uint64_t faults = 0;
  std::uint64_t recoveries = 0;
  std::uint64_t logged_rows = 0, dropped_rows = 0;
  std::vector<std::string> lifecycle;          ///< "t_s  from -> to (reason)" per transition
  std::vector<std::filesystem::path> fault_dumps;
  std::uint64_t telemetry_datagrams = 0;
  std::string log_file;
};

class RealtimeHarness {
 public:
  /// `backend` need not be configured: `start()` does it. Opens the log `log_file` with `columns`
  /// and `comments`; `label` and `duration_s` are for the progress line.
  RealtimeHarness(io::Backend& backend, const SupervisorParams& supervision, const RealtimeRunOptions& options, double period_s,
                  double duration_s, std::string label, const std::filesystem::path& log_file, const std::vector<std::string>& columns,
                  const std::vector<std::string>& comments);
  ~RealtimeHarness();
  RealtimeHarness(const RealtimeHarness&) = delete;
  RealtimeHarness& operator=(const RealtimeHarness&) = delete;

  /// The signals the harness streams beside the log's columns: the last round trip (us) and the
  /// lifecycle state (LifecycleState as a number).
  static std::vector<std::string> telemetry_extras() { return {"rtt_us", "lifecycle_state"}; }

  /// Where the experiment's loop puts its rows (the writer thread's ring, and the telemetry's tee).
  RowSink& sink() noexcept { return sink_; }
  /// Configures the calling thread for real time, starts the supervisor (configure - a board's
  /// session handshake, last in set-up - and activate), starts the clock, and returns the hooks the
  /// loop calls each cycle. Call once, on the loop's thread. Throws std::runtime_error if the
  /// backend cannot be configured (no board answers).
  CycleHooks start();
  /// Winds down (outputs disabled, -> inactive -> finalized), stops the threads, closes the log and
  /// fills `result`. Ctrl-C (SIGINT) or SIGTERM during the run end the loop at the next cycle and
  /// come here too: the log is complete up to that cycle.
  void finish(RealtimeRunResult& result);

 private:
  /// The log, then the telemetry (the row with the harness's extras).
  class Sink final : public RowSink {
   public:
    explicit Sink(RealtimeHarness& harness) : harness_(harness) {}
    void push_row(std::span<const double> row) noexcept override;

   private:
    RealtimeHarness& harness_;
  };
  bool after(const io::SensorState& state, const io::Command& sent) noexcept;

  io::Backend& backend_;
  Supervisor supervisor_;
  RealtimeRunOptions options_;
  double period_s_, duration_s_;
  std::string label_;
  AsyncCsvLog log_;
  Sink sink_;
  std::unique_ptr<LogTelemetry> telemetry_;
  PeriodicClock clock_;
  RealtimeRunResult result_;
  std::int64_t cycle_start_ns_ = 0, last_wake_ns_ = 0;
  double wake_late_s_ = 0;  ///< how late the current cycle woke
  ThreadCounters counters_at_start_;
  std::optional<ThreadCounters> counters_at_end_;  ///< at the loop's last cycle (CycleHooks::done)
  static constexpr std::size_t kOverrunEventsListed = 4096;
  std::uint64_t rtt_samples_ = 0;     ///< backend's round trips already in the statistics
  std::atomic<bool> done_{false};
  std::atomic<double> progress_t_{0.0};
  std::atomic<int> progress_state_{0};
  std::thread console_, progress_;
  bool interrupted_ = false;
  std::optional<InterruptHandler> interrupt_;  ///< from start() to finish()
};

}  // namespace peha::runtime
