#pragma once
/// \file
/// Live telemetry of any logged signal: the per-cycle log already holds every signal of a cycle, so
/// the stream is a tee at the log's row sink that picks the chosen columns of each row and
/// publishes them (runtime::Telemetry, PlotJuggler's JSON over UDP), the row's time (its first
/// column: the loop's time, simulated time in process) as the timestamp. The same selection serves a
/// run in process (`TelemetryTee` around the in-memory CsvLog) and on the board (the real-time
/// harness's sink, with the harness's own `rtt_us` and `lifecycle_state` beside the row).
///
/// A signal is named by
/// - a log column's name, exactly (`tau_motor_cmd_Nm`);
/// - a `_rad` / `_radps` column's name ending in `_deg` / `_degps` instead: that column in degrees
///   (`angle_deg` for `angle_rad`), as the files and the CLI give angles;
/// - an extra signal the host adds (the harness's `rtt_us`, `lifecycle_state`);
/// - a glob (`*` any run of characters, `?` one) over all of the above, in the log's order.
/// The set-up resolves the names to row indexes once; the loop only copies.

#include "peha/config/reader.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/runtime/telemetry.hpp"

#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace peha::runtime {

/// What to stream: the scenario's `telemetry:` section (read_telemetry) merged with the command
/// line (`--telemetry`, `--telemetry-signal`, `--telemetry-remote`; the command line wins).
struct TelemetryOptions {
  std::optional<io::UdpEndpoint> destination;  ///< PlotJuggler's UDP server; none: no stream
  double rate_Hz = 100;                        ///< samples per second of loop time
  /// The stream is unencrypted and unauthenticated: without this only a loopback destination is
  /// accepted (--telemetry-remote; never from a scenario file).
  bool allow_remote = false;
  std::vector<std::string> signals;            ///< names or globs; empty: default_telemetry_signals
};

/// The scenario's optional `telemetry:` section: `signals` (names or globs, see above),
/// `rate_Hz` (0.1..1000), `destination` ("udp://127.0.0.1:PORT", loopback only). Throws config::Error.
TelemetryOptions read_telemetry(config::Map& root);

/// Model: which value of a row (or of the host's extras) feeds each streamed signal.
struct TelemetrySelection {
  std::vector<std::string> names;    ///< the JSON keys, in order
  std::vector<std::size_t> sources;  ///< < column_count: a row's column; otherwise extras[source - column_count]
  std::vector<double> scales;        ///< 1, or 180/pi for a degree view of a radian column
  std::size_t column_count = 0;      ///< the row's width
};

/// Resolves `wanted` (names or globs; duplicates kept once) against the log's `columns` and the
/// host's `extras`; empty `wanted` gives default_telemetry_signals. Throws std::invalid_argument for
/// a name that is none of them (naming the closest) or a glob that matches nothing, or more than
/// Telemetry::kMaxSignals signals.
TelemetrySelection select_telemetry(const std::vector<std::string>& wanted, const std::vector<std::string>& columns,
                                    const std::vector<std::string>& extras = {});

/// What streams when nothing is chosen: for each joint of the log (a column prefix P, "" on a
/// one-joint log, with a column P + "agonist_loadcell_N"), its angle in degrees, both load cells,
/// both commanded pressures and the motor's commanded torque (those of them the log has), then the
/// host's `extras`.
std::vector<std::string> default_telemetry_signals(const std::vector<std::string>& columns, const std::vector<std::string>& extras = {});

/// Throws std::invalid_argument if `options` cannot stream rows of `columns` (and the host's
/// `extras`): a signal select_telemetry refuses, or a non-loopback destination without
/// `allow_remote`. Set-up checks, before anything is written; does nothing without a destination.
void check_telemetry(const TelemetryOptions& options, const std::vector<std::string>& columns, const std::vector<std::string>& extras = {});

/// Fills `values` (one per selected signal) from `row` and `extras`. noexcept, no allocation.
void pick_telemetry(const TelemetrySelection& selection, std::span<const double> row, std::span<const double> extras,
                    std::span<double> values) noexcept;

/// The stream of one log: its selection, its Telemetry (socket and sender thread) and the values
/// buffer. Built at set-up (throws as select_telemetry and Telemetry do); `publish` from the loop.
class LogTelemetry {
 public:
  /// `options.destination` must be set. `group`: the JSON object holding the signals;
  /// `queue_capacity`: samples waiting for the sender (Telemetry).
  LogTelemetry(const TelemetryOptions& options, const std::vector<std::string>& columns, const std::vector<std::string>& extras = {},
               std::string group = "peha", std::size_t queue_capacity = 256);
  /// Loop thread: the chosen values of `row` (row[0] its time, s) and `extras`, at the options' rate.
  void publish(std::span<const double> row, std::span<const double> extras = {}) noexcept;
  /// Sends what is queued and stops the sender (Telemetry::close). Idempotent.
  void close() { telemetry_.close(); }
  const TelemetrySelection& selection() const noexcept { return selection_; }
  const Telemetry& telemetry() const noexcept { return telemetry_; }
  Telemetry& telemetry() noexcept { return telemetry_; }
  const io::UdpEndpoint& destination() const noexcept { return destination_; }

 private:
  TelemetrySelection selection_;
  io::UdpEndpoint destination_;
  std::vector<double> values_;
  Telemetry telemetry_;
};

/// A row sink that hands each row to `log` and, when streaming, to a LogTelemetry: the in-process
/// runs' tee. Without a destination in `options` it only forwards.
class TelemetryTee final : public RowSink {
 public:
  TelemetryTee(RowSink& log, const TelemetryOptions& options, const std::vector<std::string>& columns);
  void push_row(std::span<const double> row) noexcept override;
  /// The stream, or nullptr when not streaming.
  LogTelemetry* telemetry() noexcept { return telemetry_.get(); }

 private:
  RowSink& log_;
  std::unique_ptr<LogTelemetry> telemetry_;
};

}  // namespace peha::runtime
