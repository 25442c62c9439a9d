#pragma once
/// \file
/// Live telemetry for PlotJuggler's "UDP Server" data source with the JSON protocol: one JSON object
/// per datagram,
///
///     {"timestamp":12.345000,"exo":{"angle_rad":0.25,"tau_motor_cmd_Nm":-1.5,"agonist_pressure_MPa":null}}
///
/// PlotJuggler names the series "/exo/angle_rad" etc. and, with "use field as timestamp" ticked,
/// plots them against "timestamp" (seconds since the loop started); otherwise against arrival time.
///
/// The loop calls `publish` every cycle; it keeps one sample per 1/rate_Hz and queues it in a
/// lock-free ring (never blocks, never allocates). A sender thread formats it (fmt, fixed buffers)
/// and sends it with a non-blocking UDP socket. A sample whose JSON would exceed kMaxDatagramBytes
/// (below a 1500-byte Ethernet MTU, so nothing is fragmented) is split over several datagrams with
/// the same timestamp, each a complete JSON object. JSON has no NaN or infinity, and PlotJuggler's
/// parser (nlohmann::json) rejects them, which stops its UDP server; they are sent as `null`, which
/// PlotJuggler skips (a gap in that series).

#include "peha/runtime/drain_thread.hpp"
#include "peha/runtime/spsc_ring.hpp"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace peha::runtime {

class Telemetry {
 public:
  static constexpr std::size_t kMaxSignals = 256;  ///< an arm's whole log row (172 columns) and its degree views
  static constexpr std::size_t kMaxDatagramBytes = 1400;
  static constexpr std::size_t kMaxNameBytes = 200;  ///< per signal and group name, after JSON escaping

  /// Sends to `host` (IPv4 dotted quad, e.g. "127.0.0.1") : `port` (PlotJuggler's default is 9870).
  /// `rate_Hz` > 0: samples per second sent (~100 is plenty for a plot). `group`: the JSON object
  /// holding the signals; `signals`: 1..kMaxSignals names (escaped for JSON here). `queue_capacity`
  /// (rounded up to a power of two): samples waiting for the sender. The stream is unencrypted and
  /// unauthenticated (the wearer's forces and angles), so it stays on this machine: `host` must be
  /// a loopback address (127.x.x.x) unless `allow_non_loopback` says otherwise. Throws
  /// std::invalid_argument for bad arguments or a refused destination, std::system_error if the
  /// socket cannot be created.
  Telemetry(const std::string& host, int port, double rate_Hz, std::string group, std::vector<std::string> signals,
            std::size_t queue_capacity = 256, bool allow_non_loopback = false);
  ~Telemetry();
  /// Throws std::invalid_argument as the constructor does for a destination it refuses (not an
  /// IPv4 address, a port outside 1..65535, not loopback without `allow_non_loopback`).
  static void check_destination(const std::string& host, int port, bool allow_non_loopback);
  Telemetry(const Telemetry&) = delete;
  Telemetry& operator=(const Telemetry&) = delete;

  /// Loop thread. `values`: one per signal, in the constructor's order; `t_s`: loop time in s,
  /// non-decreasing. Keeps the sample if at least 1/rate_Hz has passed since the last kept one
  /// (the first is always kept); a kept sample that finds the queue full, or a call with the wrong
  /// number of values, is counted in `dropped_samples`.
  void publish(double t_s, std::span<const double> values) noexcept;

  /// Waits until every sample queued before the call has been handed to the socket. Returns false
  /// on timeout.
  bool flush(std::chrono::milliseconds timeout = std::chrono::seconds(10));
  /// Sends what is queued, stops the sender thread and closes the socket. Idempotent.
  void close();

  std::uint64_t published_samples() const noexcept { return published_.load(std::memory_order_relaxed); }  ///< kept and queued
  std::uint64_t dropped_samples() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t sent_datagrams() const noexcept { return sent_.load(std::memory_order_relaxed); }
  std::uint64_t send_errors() const noexcept { return send_errors_.load(std::memory_order_relaxed); }  ///< datagrams lost in sendto

 private:
  struct Sample {
    double t_s;
    double values[kMaxSignals];
  };

  bool sender_step() noexcept;
  void send_datagram(const char* data, std::size_t size) noexcept;

  struct Socket {
    int fd;
    explicit Socket(int f) : fd(f) {}
    Socket(const Socket&) = delete;
    Socket& operator=(const Socket&) = delete;
    ~Socket();
  };

  std::string destination_;                ///< "host:port", for messages
  alignas(8) std::array<unsigned char, 16> address_;  ///< sockaddr_in of the destination
  std::string head_;                 ///< {"timestamp":
  std::string group_open_;           ///< ,"<group>":{
  std::vector<std::string> keys_;    ///< "<signal>":   (escaped)
  double interval_s_;
  Socket socket_;

  SpscRing<Sample> queue_;
  double next_publish_t_s_;          ///< loop side
  std::atomic<bool> closing_{false};
  std::atomic<std::uint64_t> published_{0}, dropped_{0};  ///< written by the loop only
  std::atomic<std::uint64_t> sent_{0}, send_errors_{0};   ///< written by the sender only
  Sample sample_{};                  ///< sender side: the one being sent
  bool error_reported_ = false;      ///< sender side: the first send error was logged
  DrainThread sender_;               ///< last: started after, stopped before, everything above
};

}  // namespace peha::runtime
