#pragma once
/// \file
/// E1 on the multifunction board over UDP, in real time (SPEC §5): the same controller, limits
/// and analysis as the in-process run (`run_e1_on`), paced by an absolute-deadline 1 kHz clock on
/// a thread configured for real time (SCHED_FIFO, mlockall, CPU affinity when permitted; loud
/// warnings when not), with the board's lifecycle, every cycle logged by a writer thread, a fault
/// dump of the last seconds, optional PlotJuggler telemetry, and timing statistics.
///
/// Lifecycle (runtime::Lifecycle): unconfigured -> configure (socket, session handshake) ->
/// inactive -> activate (enable edge) -> active. Faults: the board silent for host_watchdog_ms, its
/// watchdog tripped, or its e-stop input -> fault: outputs disabled (the board holds its safe
/// outputs and vents slowly), the last seconds dumped. Recovery only on the operator's command
/// (`r` + Enter on the terminal, or `recover_after_s` for unattended runs) and only once the board
/// reports no e-stop: fault -> recovering (enable edge again; commands ramp from the safe command
/// to the controller's over recovery_ramp_s: no jump) -> inactive -> active.

#include "peha/mfb/udp_backend.hpp"
#include "peha/runtime/e1_gravity.hpp"
#include "peha/runtime/lifecycle.hpp"
#include "peha/runtime/realtime.hpp"
#include "peha/runtime/timing_stats.hpp"

#include <filesystem>
#include <optional>
#include <string>

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

struct RealtimeRunResult {
  E1Result e1;
  LoopTiming timing;
  mfb::UdpLinkStats link;
  RealtimeReport realtime;
  std::uint64_t faults = 0;
  std::uint64_t recoveries = 0;
  std::uint64_t logged_rows = 0, dropped_rows = 0;
  std::vector<std::string> lifecycle;          ///< "t_s from -> to (reason)" per transition
  std::vector<std::filesystem::path> fault_dumps;
  std::uint64_t telemetry_datagrams = 0;
  std::string log_file;
};

/// Runs one E1 case on the board at `options.board`. Throws (set-up) if the scenario has no `mfb:`
/// section, the channel map is bad, or no board answers within the connect timeout.
RealtimeRunResult run_e1_realtime(const E1Scenario& scenario, const E1Case& c, const RealtimeRunOptions& options);

}  // namespace peha::runtime
