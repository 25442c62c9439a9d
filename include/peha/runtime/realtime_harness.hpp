#pragma once
/// \file
/// What every experiment needs to run in real time on the multifunction board (SPEC §5), around
/// its own loop (`run_e1_on`, `run_postures_on`, ...): the absolute-deadline clock, the real-time
/// thread set-up with its warnings, the board's lifecycle with fault detection and the operator's
/// recovery path (commands ramped back, no jump), the writer-thread CSV log with fault dumps,
/// optional PlotJuggler telemetry, a progress line and the timing statistics. The experiment's loop
/// gets `hooks()` (pacing and supervision) and `sink()` (its log rows).
///
/// Lifecycle (runtime::Lifecycle): unconfigured -> configure (the session handshake,
/// UdpBackend::connect, done by `start()` after every other set-up step so that the enable edge
/// follows the board's first answer within a period: until then the board holds its safe outputs
/// and its plant vents) -> inactive -> activate (enable edge) -> active. Faults: the board silent
/// (no new sample for host_watchdog_ms *and* for kSilentCycles of the host's own cycles in a row -
/// a host that was itself descheduled has not heard a dead board, it has not listened), its
/// watchdog tripped, or its e-stop (status bit or input line) -> fault: outputs disabled (the
/// board holds its safe outputs and vents slowly), the last 5 s dumped. Recovery only on the operator's command (`r` + Enter on the
/// terminal, or `recover_after_s` for unattended runs) and only once the board is alive and its
/// e-stop released: fault -> recovering (a new enable edge; the commands ramp from the pressures the
/// muscles hold to the controller's over recovery_ramp_s) -> inactive -> active.

#include "peha/mfb/udp_backend.hpp"
#include "peha/runtime/async_log.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/runtime/lifecycle.hpp"
#include "peha/runtime/realtime.hpp"
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
  io::UdpEndpoint board;                       ///< from --backend udp://A.B.C.D:PORT
  RealtimeOptions realtime;                    ///< SCHED_FIFO priority, CPU, mlockall
  std::optional<io::UdpEndpoint> telemetry;    ///< PlotJuggler UDP server, if streaming
  double telemetry_rate_Hz = 100;
  double recover_after_s = -1;                 ///< unattended operator: recover this long after a fault (< 0: only 'r' on stdin)
  std::filesystem::path dir;                   ///< run directory: log, fault dumps, timing
  bool quiet = false;                          ///< no progress line
};

/// What the harness measured (the experiment's own figures come with its runner).
struct RealtimeRunResult {
  LoopTiming timing;
  mfb::UdpLinkStats link;
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
  /// The board counts as silent only after this many of the host's cycles in a row brought no new
  /// sample (besides host_watchdog_ms without one). On a machine that froze as a whole (a VM's
  /// host, 20 ms seen here) the board froze too; its replies come within the next cycle or two.
  /// At 1 kHz this adds nothing to the 20 ms detection time of a board that really stopped.
  static constexpr int kSilentCycles = 5;

  /// `backend` need not be connected: `start()` opens the session. Opens the log `log_file` with
  /// `columns` and `comments`; `label` and `duration_s` are for the progress line.
  RealtimeHarness(mfb::UdpBackend& backend, const mfb::LinkConfig& link, const RealtimeRunOptions& options, double period_s,
                  double duration_s, std::string label, const std::filesystem::path& log_file, const std::vector<std::string>& columns,
                  const std::vector<std::string>& comments);
  ~RealtimeHarness();
  RealtimeHarness(const RealtimeHarness&) = delete;
  RealtimeHarness& operator=(const RealtimeHarness&) = delete;

  /// Where the experiment's loop puts its rows (the writer thread's ring).
  RowSink& sink() noexcept { return sink_; }
  /// Configures the calling thread for real time, opens the board's session (UdpBackend::connect;
  /// re-confirms it if the caller connected earlier), sends the enable edge (-> active), starts
  /// the clock, and returns the hooks the loop calls each cycle. Call once, on the loop's thread.
  /// Throws std::runtime_error if the board does not answer.
  CycleHooks start();
  /// Winds down (outputs disabled, -> inactive -> finalized), stops the threads, closes the log and
  /// fills `result`. Ctrl-C (SIGINT) or SIGTERM during the run end the loop at the next cycle and
  /// come here too: the log is complete up to that cycle.
  void finish(RealtimeRunResult& result);

 private:
  class Sink final : public RowSink {
   public:
    explicit Sink(AsyncCsvLog& log) : log_(log) {}
    void push_row(std::span<const double> row) noexcept override { log_.push(row); }

   private:
    AsyncCsvLog& log_;
  };
  bool after(const io::SensorState& state, io::Command& command) noexcept;

  mfb::UdpBackend& backend_;
  mfb::LinkConfig link_;
  RealtimeRunOptions options_;
  double period_s_, duration_s_;
  std::string label_;
  AsyncCsvLog log_;
  Sink sink_;
  std::unique_ptr<Telemetry> telemetry_;
  std::vector<double> telemetry_values_;
  Lifecycle lifecycle_;
  PeriodicClock clock_;
  RealtimeRunResult result_;
  std::int64_t cycle_start_ns_ = 0, last_wake_ns_ = 0;
  std::int64_t seen_sample_ns_ = 0;   ///< backend's last_sample_ns() at the previous cycle
  int cycles_without_sample_ = 0;     ///< host cycles in a row that brought no new sample
  double fault_t_ = -1.0, ramp_t_ = -1.0;
  io::Command ramp_from_;
  std::atomic<bool> operator_recover_{false};
  std::atomic<bool> done_{false};
  std::atomic<double> progress_t_{0.0};
  std::atomic<int> progress_state_{0};
  std::thread console_, progress_;
  bool interrupted_ = false;
  void (*previous_sigint_)(int) = nullptr;
  void (*previous_sigterm_)(int) = nullptr;
};

}  // namespace peha::runtime
