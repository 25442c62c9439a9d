#pragma once
/// \file
/// A small IPv4 UDP socket for the MFB link (host and board emulator): set-up throws with the
/// errno text, the per-cycle calls (send, receive, wait) are noexcept and allocation-free.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace peha::io {

/// CLOCK_MONOTONIC now, ns: the clock of the link's time stamps (round trips, watchdogs).
std::int64_t monotonic_ns() noexcept;

/// An IPv4 address and port, both in host byte order.
struct UdpEndpoint {
  std::uint32_t address = 0;  ///< e.g. 0x7F000001 for 127.0.0.1
  std::uint16_t port = 0;
  bool operator==(const UdpEndpoint&) const = default;
  std::string to_string() const;  ///< "127.0.0.1:50000"
};

/// Parses a numeric IPv4 address "A.B.C.D" (host byte order). Throws std::invalid_argument.
std::uint32_t parse_ipv4(const std::string& text);

/// Parses "udp://A.B.C.D:PORT" or "A.B.C.D:PORT" (numeric IPv4 only, port 1..65535).
/// Throws std::invalid_argument naming what is wrong.
UdpEndpoint parse_udp_endpoint(const std::string& text);

class UdpSocket {
 public:
  /// Binds to `local` (port 0 = any free port). Throws std::runtime_error with errno's text.
  explicit UdpSocket(const UdpEndpoint& local);
  ~UdpSocket();
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;

  /// The bound address (with the port the kernel chose when asked for 0).
  const UdpEndpoint& local() const noexcept { return local_; }
  /// Sends one datagram; false if the kernel refused it (counted by the caller).
  bool send_to(const UdpEndpoint& to, std::span<const std::uint8_t> bytes) noexcept;
  /// Receives one datagram without blocking into `buffer`; returns its size (a datagram longer
  /// than the buffer is reported with its full size so the caller can reject it), -1 if none.
  long receive(std::span<std::uint8_t> buffer, UdpEndpoint& from) noexcept;
  /// Waits until a datagram is readable or `timeout_ns` (>= 0) passes; true if readable.
  bool wait_readable(std::int64_t timeout_ns) noexcept;
  int fd() const noexcept { return fd_; }

 private:
  int fd_ = -1;
  UdpEndpoint local_;
};

}  // namespace peha::io
