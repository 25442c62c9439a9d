#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <sys/stat.h>

namespace peha::mfb {

LinkConfig read_link_config(config::Map map) {
  LinkConfig l;
  l.channel_map = map.path_value("channel_map");
  l.key_file = map.path_value("key_file");
  l.board_watchdog_s = map.number("board_watchdog_ms", {2.0, 10000.0}) * 1e-3;
  l.host_watchdog_s = map.number("host_watchdog_ms", {2.0, 10000.0}) * 1e-3;
  l.receive_timeout_s = map.number("receive_timeout_ms", {0.05, 100.0}) * 1e-3;
  l.vent_s = map.number("vent_s", {0.0, 60.0});
  l.recovery_ramp_s = map.number("recovery_ramp_s", {0.0, 60.0});
  map.finish();
  return l;
}

LinkKey load_link_key(const std::filesystem::path& path) {
  const std::string name = path.string();
  struct stat st {};
  if (::stat(name.c_str(), &st) != 0) {
    throw std::runtime_error(fmt::format("MFB key file {}: {} (the mfb: section's key_file; see docs/mfb-protocol.md#authentication)", name,
                                         std::strerror(errno)));
  }
  if (!S_ISREG(st.st_mode)) throw std::runtime_error(fmt::format("MFB key file {}: not a regular file", name));
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    throw std::runtime_error(fmt::format("MFB key file {} is accessible by group or others (mode {:04o}): refusing a secret key anyone "
                                         "on this machine may read; run 'chmod 600 {}'",
                                         name, st.st_mode & 07777, name));
  }
  if (st.st_size > 4096) throw std::runtime_error(fmt::format("MFB key file {}: {} bytes, expected 64 hex digits", name, st.st_size));
  std::ifstream in(path);
  std::string hex, line;
  while (std::getline(in, line)) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (const char c : line) {
      if (c != ' ' && c != '\t' && c != '\r') hex += c;
    }
  }
  auto digit = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  LinkKey key;
  bool valid = hex.size() == 2 * kKeySize;
  bool nonzero = false;
  for (std::size_t i = 0; valid && i < kKeySize; ++i) {
    const int hi = digit(hex[2 * i]), lo = digit(hex[2 * i + 1]);
    valid = hi >= 0 && lo >= 0;
    key.bytes[i] = static_cast<std::uint8_t>(valid ? hi * 16 + lo : 0);
    nonzero = nonzero || key.bytes[i] != 0;
  }
  if (!valid) {
    throw std::runtime_error(fmt::format("MFB key file {}: expected exactly {} hex digits (the {}-byte key; make one with "
                                         "'head -c 32 /dev/urandom | od -An -tx1 | tr -d \" \\n\"'), found {} characters",
                                         name, 2 * kKeySize, kKeySize, hex.size()));
  }
  if (!nonzero) throw std::runtime_error(fmt::format("MFB key file {}: the key is all zero", name));
  return key;
}

std::unique_ptr<UdpBackend> make_board_backend(const LinkConfig& link, const io::UdpEndpoint& board, double period_s,
                                               const std::vector<std::string>& joint_names) {
  UdpBackendParams bp;
  bp.board = board;
  bp.period_s = period_s;
  bp.receive_timeout_s = link.receive_timeout_s;
  bp.joint_names = joint_names;
  bp.key = load_link_key(link.key_file);
  return std::make_unique<UdpBackend>(bp, read_channel_map(config::Document::load_file(link.channel_map), joint_names));
}

}  // namespace peha::mfb
