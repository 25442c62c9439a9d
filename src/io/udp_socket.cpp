#include "peha/io/udp_socket.hpp"

#include <fmt/format.h>

#include <arpa/inet.h>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdexcept>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

namespace peha::io {
namespace {

sockaddr_in to_sockaddr(const UdpEndpoint& e) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(e.address);
  a.sin_port = htons(e.port);
  return a;
}

}  // namespace

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

std::string UdpEndpoint::to_string() const {
  return fmt::format("{}.{}.{}.{}:{}", address >> 24, (address >> 16) & 0xFF, (address >> 8) & 0xFF, address & 0xFF, port);
}

std::uint32_t parse_ipv4(const std::string& text) {
  in_addr addr{};
  if (inet_pton(AF_INET, text.c_str(), &addr) != 1) {
    throw std::invalid_argument(fmt::format("'{}' is not a numeric IPv4 address", text));
  }
  return ntohl(addr.s_addr);
}

UdpEndpoint parse_udp_endpoint(const std::string& text) {
  std::string rest = text;
  if (rest.rfind("udp://", 0) == 0) rest = rest.substr(6);
  const auto colon = rest.rfind(':');
  if (colon == std::string::npos) {
    throw std::invalid_argument(fmt::format("'{}': expected udp://A.B.C.D:PORT (numeric IPv4 address and a port)", text));
  }
  const std::string host = rest.substr(0, colon);
  std::uint32_t address = 0;
  try {
    address = parse_ipv4(host);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("'{}': {}", text, e.what()));
  }
  const std::string port_text = rest.substr(colon + 1);
  unsigned port = 0;
  const auto [ptr, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || ptr != port_text.data() + port_text.size() || port == 0 || port > 65535) {
    throw std::invalid_argument(fmt::format("'{}': port must be 1..65535, found '{}'", text, port_text));
  }
  return {address, static_cast<std::uint16_t>(port)};
}

UdpSocket::UdpSocket(const UdpEndpoint& local) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(fmt::format("UDP socket: {}", std::strerror(errno)));
  const sockaddr_in a = to_sockaddr(local);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    const int err = errno;
    ::close(fd_);
    throw std::runtime_error(fmt::format("UDP bind to {}: {}", local.to_string(), std::strerror(err)));
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&bound), &len);
  local_ = {ntohl(bound.sin_addr.s_addr), ntohs(bound.sin_port)};
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) ::close(fd_);
}

bool UdpSocket::send_to(const UdpEndpoint& to, std::span<const std::uint8_t> bytes) noexcept {
  const sockaddr_in a = to_sockaddr(to);
  const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  return n == static_cast<ssize_t>(bytes.size());
}

long UdpSocket::receive(std::span<std::uint8_t> buffer, UdpEndpoint& from) noexcept {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  // MSG_TRUNC: the return value is the datagram's real length even when it did not fit.
  const ssize_t n = ::recvfrom(fd_, buffer.data(), buffer.size(), MSG_TRUNC, reinterpret_cast<sockaddr*>(&a), &len);
  if (n < 0) return -1;
  from = {ntohl(a.sin_addr.s_addr), ntohs(a.sin_port)};
  return static_cast<long>(n);
}

bool UdpSocket::wait_readable(std::int64_t timeout_ns) noexcept {
  pollfd p{fd_, POLLIN, 0};
  // ppoll for sub-millisecond timeouts.
  timespec ts{static_cast<time_t>(timeout_ns / 1000000000), static_cast<long>(timeout_ns % 1000000000)};
  return ::ppoll(&p, 1, &ts, nullptr) > 0 && (p.revents & POLLIN);
}

}  // namespace peha::io
