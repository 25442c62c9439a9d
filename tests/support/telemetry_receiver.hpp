#pragma once
// PlotJuggler's side of the telemetry wire, for tests: a UDP socket bound to 127.0.0.1 on a free
// port, a thread that keeps every datagram while a run streams, and a reader of the flat JSON
// objects runtime::Telemetry sends.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace peha::testing {

class TelemetryReceiver {
 public:
  TelemetryReceiver() {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    socklen_t len = sizeof(addr);
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    const int buffer = 4 << 20;
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &buffer, sizeof(buffer));
    timeval timeout{5, 0};  // generous: only reached if a datagram is missing
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  }
  ~TelemetryReceiver() {
    stop();
    ::close(fd_);
  }
  TelemetryReceiver(const TelemetryReceiver&) = delete;
  TelemetryReceiver& operator=(const TelemetryReceiver&) = delete;

  int port() const { return port_; }
  /// The next datagram, or "" after the timeout.
  std::string receive() {
    char buffer[65536];
    const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : std::string();
  }
  /// Whether a datagram arrives within `ms`.
  bool nothing_more(int ms) {
    timeval timeout{0, ms * 1000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    return receive().empty();
  }
  /// Keeps every datagram on a thread (while another process streams) until `stop`.
  void start_collecting() {
    timeval timeout{0, 100000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    thread_ = std::thread([this] {
      while (!stop_) {
        std::string d = receive();
        if (d.empty()) continue;
        const std::lock_guard lock(mutex_);
        collected_.push_back(std::move(d));
      }
    });
  }
  /// Stops collecting (after what is already in the socket) and returns everything collected.
  std::vector<std::string> stop() {
    if (thread_.joinable()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      stop_ = true;
      thread_.join();
    }
    const std::lock_guard lock(mutex_);
    return collected_;
  }

 private:
  int fd_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<std::string> collected_;
};

/// One datagram `{"timestamp":T,"<group>":{"k":v,...}}`: its time and its entries in order (null: NaN).
struct TelemetrySample {
  double timestamp = std::nan("");
  std::vector<std::pair<std::string, double>> values;
};

/// Reads a datagram as runtime::Telemetry writes it (no nesting beyond the group, names without
/// escapes); an empty sample if it is not one.
inline TelemetrySample parse_telemetry(const std::string& json, const std::string& group) {
  TelemetrySample s;
  const std::string head = "{\"timestamp\":";
  if (json.rfind(head, 0) != 0) return s;
  s.timestamp = std::strtod(json.c_str() + head.size(), nullptr);
  std::size_t p = json.find("\"" + group + "\":{");
  if (p == std::string::npos) return s;
  p += group.size() + 4;
  while (p < json.size() && json[p] == '"') {
    const std::size_t end = json.find("\":", p + 1);
    const std::string key = json.substr(p + 1, end - p - 1);
    const char* value = json.c_str() + end + 2;
    s.values.emplace_back(key, json.compare(end + 2, 4, "null") == 0 ? std::nan("") : std::strtod(value, nullptr));
    p = json.find_first_of(",}", end + 2);
    if (p == std::string::npos || json[p] == '}') break;
    ++p;
  }
  return s;
}

}  // namespace peha::testing
