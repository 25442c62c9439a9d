#include "peha/runtime/telemetry.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <system_error>

namespace peha::runtime {
namespace {

static_assert(sizeof(sockaddr_in) <= 16);

// PlotJuggler's loop time stamps come 1 ms apart at 1 kHz but are sums of floating-point periods:
// a sample due at exactly 10 ms may carry 9.999999999 ms. Keep it.
constexpr double kDueTolerance_s = 1e-6;
// "{:.9g}" of a finite double, or "null": at most 16 characters.
constexpr std::size_t kMaxTelemetryValueChars = 24;

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      out += fmt::format("\\u{:04x}", c);
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string checked_name(const std::string& kind, const std::string& name) {
  std::string quoted = json_string(name);
  if (name.empty() || quoted.size() > Telemetry::kMaxNameBytes) {
    throw std::invalid_argument(
        fmt::format("Telemetry: {} name '{}' is empty or longer than {} bytes", kind, name, Telemetry::kMaxNameBytes));
  }
  return quoted;
}

char* write_number(char* p, double v) noexcept {
  if (!std::isfinite(v)) return fmt::format_to(p, FMT_COMPILE("null"));
  return fmt::format_to(p, FMT_COMPILE("{:.9g}"), v);
}

std::array<unsigned char, 16> checked_address(const std::string& host, int port, bool allow_non_loopback) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    throw std::invalid_argument(fmt::format("Telemetry: host '{}' is not an IPv4 address like 127.0.0.1", host));
  }
  if ((ntohl(addr.sin_addr.s_addr) >> 24) != 127 && !allow_non_loopback) {
    throw std::invalid_argument(fmt::format("Telemetry: refusing to stream to {}, which is not a loopback address: the stream is "
                                            "unencrypted and unauthenticated (the wearer's forces and angles). Run PlotJuggler on "
                                            "this machine (udp://127.0.0.1:{}), or allow a remote destination explicitly",
                                            host, port));
  }
  if (port < 1 || port > 65535) throw std::invalid_argument(fmt::format("Telemetry: port {} is not in 1..65535", port));
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  std::array<unsigned char, 16> bytes{};
  std::memcpy(bytes.data(), &addr, sizeof(addr));
  return bytes;
}

double checked_interval(double rate_Hz) {
  if (!(rate_Hz > 0) || !std::isfinite(rate_Hz)) {
    throw std::invalid_argument(fmt::format("Telemetry: rate_Hz must be > 0, got {}", rate_Hz));
  }
  return 1.0 / rate_Hz;
}

std::vector<std::string> checked_keys(const std::vector<std::string>& signals) {
  if (signals.empty() || signals.size() > Telemetry::kMaxSignals) {
    throw std::invalid_argument(
        fmt::format("Telemetry: expected 1..{} signals, got {}", Telemetry::kMaxSignals, signals.size()));
  }
  std::vector<std::string> keys;
  for (const std::string& s : signals) keys.push_back(checked_name("signal", s) + ":");
  return keys;
}

int open_socket() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "Telemetry: socket");
  return fd;
}

}  // namespace

Telemetry::Socket::~Socket() {
  if (fd >= 0) ::close(fd);
}

// Everything the sender touches is built in the initialiser list, before the sender (last) starts.
Telemetry::Telemetry(const std::string& host, int port, double rate_Hz, std::string group,
                     std::vector<std::string> signals, std::size_t queue_capacity, bool allow_non_loopback)
    : destination_(fmt::format("{}:{}", host, port)),
      address_(checked_address(host, port, allow_non_loopback)),
      head_("{\"timestamp\":"),
      group_open_(fmt::format(",{}:{{", checked_name("group", group))),
      keys_(checked_keys(signals)),
      interval_s_(checked_interval(rate_Hz)),
      socket_(open_socket()),
      queue_(std::bit_ceil(std::max<std::size_t>(queue_capacity, 1))),
      next_publish_t_s_(-std::numeric_limits<double>::infinity()),
      sender_("peha-telemetry", {[this] { return sender_step(); }, {}, {}}) {}

Telemetry::~Telemetry() { close(); }

void Telemetry::check_destination(const std::string& host, int port, bool allow_non_loopback) {
  (void)checked_address(host, port, allow_non_loopback);
}

void Telemetry::publish(double t_s, std::span<const double> values) noexcept {
  if (!(t_s + kDueTolerance_s >= next_publish_t_s_)) return;  // not due yet (or t_s is NaN)
  next_publish_t_s_ += interval_s_;
  if (next_publish_t_s_ <= t_s) next_publish_t_s_ = t_s + interval_s_;  // first sample, or after a gap
  const bool queued = values.size() == keys_.size() && !closing_.load(std::memory_order_relaxed) &&
                      queue_.try_push_with([&](Sample& s) noexcept {
                        s.t_s = t_s;
                        std::copy(values.begin(), values.end(), s.values);
                      });
  std::atomic<std::uint64_t>& counter = queued ? published_ : dropped_;
  counter.store(counter.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

bool Telemetry::sender_step() noexcept {
  if (!queue_.try_pop(sample_)) return false;
  // {"timestamp":<t>,"<group>":{"<a>":<v>,"<b>":<v>}} ; split before an entry that would not fit.
  char datagram[kMaxDatagramBytes];
  char* p = std::copy(head_.begin(), head_.end(), datagram);
  p = std::isfinite(sample_.t_s) ? fmt::format_to(p, FMT_COMPILE("{:.6f}"), sample_.t_s) : write_number(p, sample_.t_s);
  p = std::copy(group_open_.begin(), group_open_.end(), p);
  char* const body = p;
  constexpr std::size_t kClose = 2;  // "}}"
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    char entry[kMaxNameBytes + 1 + kMaxTelemetryValueChars];
    char* e = std::copy(keys_[i].begin(), keys_[i].end(), entry);
    e = write_number(e, sample_.values[i]);
    const auto entry_size = static_cast<std::size_t>(e - entry);
    const bool first = p == body;
    if (!first && static_cast<std::size_t>(p - datagram) + 1 + entry_size + kClose > kMaxDatagramBytes) {
      *p++ = '}';
      *p++ = '}';
      send_datagram(datagram, static_cast<std::size_t>(p - datagram));
      p = body;
    }
    if (p != body) *p++ = ',';
    p = std::copy(entry, e, p);
  }
  *p++ = '}';
  *p++ = '}';
  send_datagram(datagram, static_cast<std::size_t>(p - datagram));
  return true;
}

void Telemetry::send_datagram(const char* data, std::size_t size) noexcept {
  const ssize_t n = ::sendto(socket_.fd, data, size, MSG_DONTWAIT | MSG_NOSIGNAL,
                             reinterpret_cast<const sockaddr*>(address_.data()), sizeof(sockaddr_in));
  if (n == static_cast<ssize_t>(size)) {
    sent_.store(sent_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    return;
  }
  const int err = errno;
  send_errors_.store(send_errors_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  if (!error_reported_) {  // once: the counter tells the rest
    error_reported_ = true;
    spdlog::warn("telemetry: sendto {} failed ({}); further failures are only counted", destination_,
                 std::strerror(err));
  }
}

bool Telemetry::flush(std::chrono::milliseconds timeout) { return sender_.flush(timeout); }

void Telemetry::close() {
  closing_.store(true, std::memory_order_relaxed);
  sender_.stop();
}

}  // namespace peha::runtime
