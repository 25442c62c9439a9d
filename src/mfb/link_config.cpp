#include "peha/mfb/link_config.hpp"

#include "peha/config/input_file.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <sodium.h>

#include <array>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace peha::mfb {

namespace {

/// The io joints a board's channel map carries (its encoders' joints: every joint has exactly one),
/// after checking that the map fits one board. config::Error at the map's field otherwise.
std::vector<std::string> board_joints(const BoardLink& board, const std::vector<std::string>& io_joints) {
  const config::Document doc = config::Document::load_file(board.channel_map);
  config::Map root = doc.root();
  struct Kind {
    const char* key;
    int channels;
    const char* what;
  };
  for (const Kind& k : {Kind{"analog_inputs", kAdChannels, "AD"}, Kind{"analog_outputs", kDaChannels, "DA"},
                        Kind{"encoders", kEncoderChannels, "encoder"}}) {
    if (!root.has(k.key)) continue;  // the map reader names what is missing
    const std::size_t n = root.maps(k.key, 0, 1000).size();
    if (n > static_cast<std::size_t>(k.channels)) {
      root.fail(k.key, fmt::format("board '{}' does not fit one board: it has {} {} channels, this map asks for {} (split its joints "
                                   "over more boards: docs/channel-maps.md)",
                                   board.name, k.channels, k.what, n));
    }
  }
  std::vector<std::string> joints;
  if (!root.has("encoders")) return joints;
  for (config::Map item : root.maps("encoders", 0, kEncoderChannels)) {
    const std::string joint = item.string("joint");
    if (std::find(io_joints.begin(), io_joints.end(), joint) == io_joints.end()) {
      item.fail("joint", fmt::format("board '{}': '{}' is not an io joint of the scenario (expected one of {})", board.name, joint,
                                     fmt::join(io_joints, ", ")));
    }
    joints.push_back(joint);
  }
  return joints;
}

/// Gives each board its io joints (in io order) and reads its channel map with them: every io
/// joint on exactly one board.
void assign_joints(config::Map& map, LinkConfig& l, const std::vector<std::string>& io_joints) {
  std::vector<int> board_of(io_joints.size(), -1);
  for (std::size_t b = 0; b < l.boards.size(); ++b) {
    for (const std::string& joint : board_joints(l.boards[b], io_joints)) {
      const auto j = static_cast<std::size_t>(std::find(io_joints.begin(), io_joints.end(), joint) - io_joints.begin());
      if (board_of[j] >= 0 && board_of[j] != static_cast<int>(b)) {
        const BoardLink& first = l.boards[static_cast<std::size_t>(board_of[j])];
        map.fail("boards", fmt::format("io joint '{}' is on two boards: '{}' ({}) and '{}' ({}); expected every io joint on exactly one board",
                                       joint, first.name, first.channel_map.string(), l.boards[b].name, l.boards[b].channel_map.string()));
      }
      board_of[j] = static_cast<int>(b);
    }
  }
  for (std::size_t j = 0; j < io_joints.size(); ++j) {
    if (board_of[j] < 0) {
      map.fail("boards", fmt::format("io joint '{}' is on no board: no board's channel map has an encoder for it; expected every io joint "
                                     "({}) on exactly one board",
                                     io_joints[j], fmt::join(io_joints, ", ")));
    }
    l.boards[static_cast<std::size_t>(board_of[j])].joint_names.push_back(io_joints[j]);
  }
  for (BoardLink& b : l.boards) {
    if (b.joint_names.empty()) {
      map.fail("boards", fmt::format("board '{}' ({}) carries no io joint; expected at least one", b.name, b.channel_map.string()));
    }
    (void)read_channel_map(config::Document::load_file(b.channel_map), b.joint_names);  // the rest of its schema
  }
}

}  // namespace

LinkConfig read_link_config(config::Map map, const std::vector<std::string>& io_joints) {
  LinkConfig l;
  if (map.has("boards")) {
    if (map.has("channel_map")) map.fail("channel_map", "give either channel_map (one board) or boards (several), not both");
    const bool shared_key = map.has("key_file");
    const std::filesystem::path key = shared_key ? map.path_value("key_file") : std::filesystem::path();
    for (config::Map item : map.maps("boards", 1, kMaxBoards)) {
      BoardLink b;
      b.name = item.string("name");
      for (const BoardLink& other : l.boards) {
        if (other.name == b.name) item.fail("name", fmt::format("board name '{}' appears twice; expected one name per board", b.name));
      }
      b.channel_map = item.path_value("channel_map");
      if (!shared_key && !item.has("key_file")) {
        item.fail("", "missing key_file: give each board its key_file, or one key_file for all in the mfb: section");
      }
      b.key_file = item.has("key_file") ? item.path_value("key_file") : key;
      item.finish();
      l.boards.push_back(std::move(b));
    }
  } else {
    l.boards.push_back({"", map.path_value("channel_map"), map.path_value("key_file"), io_joints});
  }
  l.channel_map = l.boards.front().channel_map;
  l.key_file = l.boards.front().key_file;
  // The lifecycle supervisor's parameters hold in process too: the scenario's lifecycle: section.
  map.refuse_moved("host_watchdog_ms", "give it as lifecycle.host_watchdog_ms (the lifecycle supervisor's, in process and on the board)");
  map.refuse_moved("recovery_ramp_s", "give it as lifecycle.recovery_ramp_s (the lifecycle supervisor's, in process and on the board)");
  // Hard bound: 100 ms of a stale command at full pressure is as long as a person may be exposed to it.
  l.board_watchdog_s = map.number("board_watchdog_ms", {2.0, 100.0}) * 1e-3;
  l.receive_timeout_s = map.number("receive_timeout_ms", {0.05, 100.0}) * 1e-3;
  l.vent_s = map.number("vent_s", {0.0, 10.0});
  map.finish();
  if (!io_joints.empty() && l.boards.size() > 1) assign_joints(map, l, io_joints);
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
  std::istringstream in(config::read_input_file(path, config::InputKind::kKey));
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
  std::array<bool, 256> seen{};
  int distinct = 0;
  for (const std::uint8_t b : key.bytes) distinct += seen[b] ? 0 : (seen[b] = true, 1);
  if (distinct < kMinDistinctKeyBytes) {
    throw std::runtime_error(fmt::format("MFB key file {}: a key of low entropy ({} distinct byte value(s), expected at least {}: a "
                                         "typed pattern, not random bytes); make one with 'peha keygen --out {}.new'",
                                         name, distinct, kMinDistinctKeyBytes, name));
  }
  return key;
}

void write_new_link_key(const std::filesystem::path& path) {
  if (sodium_init() < 0) throw std::runtime_error("peha keygen: libsodium failed to initialise (no entropy source?)");
  LinkKey key;
  do {
    randombytes_buf(key.bytes.data(), key.bytes.size());
  } while (is_development_key(key));  // 1 in 2^256; stated so that the loop's purpose is plain
  std::string text = "# MFB link key (peha keygen): 32 random bytes as 64 hex digits. Keep it secret: host and board read it.\n";
  for (const std::uint8_t b : key.bytes) text += fmt::format("{:02x}", b);
  text += "\n";
  sodium_memzero(key.bytes.data(), key.bytes.size());
  // O_EXCL: never replaces an existing file; 0600 from the start, so the key is never readable by others.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int e = errno;
    throw std::runtime_error(e == EEXIST ? fmt::format("peha keygen: {} exists; refusing to overwrite a key (remove it first if you mean "
                                                       "to replace it, and give the board the new one)",
                                                       path.string())
                                         : fmt::format("peha keygen: cannot create {}: {}", path.string(), std::strerror(e)));
  }
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = errno;
      ::close(fd);
      ::unlink(path.c_str());
      throw std::runtime_error(fmt::format("peha keygen: writing {}: {}", path.string(), std::strerror(e)));
    }
    done += static_cast<std::size_t>(n);
  }
  sodium_memzero(text.data(), text.size());
  if (::fsync(fd) != 0 || ::close(fd) != 0) throw std::runtime_error(fmt::format("peha keygen: writing {}: {}", path.string(), std::strerror(errno)));
}

bool is_development_key(const LinkKey& key) noexcept {
  // configs/mfb/dev_link.key: public, in the repository.
  static constexpr std::array<std::uint8_t, kKeySize> kDevelopment = {
      0x5e, 0x2b, 0x16, 0x1c, 0x0a, 0x8c, 0xf2, 0x64, 0x45, 0xf8, 0x64, 0x2c, 0x8a, 0x85, 0x39, 0x78,
      0x42, 0x16, 0xe5, 0x04, 0x5d, 0xff, 0xe2, 0x39, 0x26, 0xb4, 0x0b, 0x21, 0xa4, 0xfe, 0x4d, 0xec};
  return key.bytes == kDevelopment;
}

void require_private_key_off_loopback(const LinkKey& key, std::uint32_t address, const std::string& role) {
  if (!is_development_key(key) || (address >> 24) == 127) return;
  throw std::runtime_error(fmt::format("MFB link: the {} address {} is not loopback (127.0.0.0/8), and the key is the public development "
                                       "key (configs/mfb/dev_link.key): anyone could drive this board. Make this installation's own key "
                                       "with 'peha keygen --out FILE' and name it in the scenario's mfb: key_file (docs/commissioning.md)",
                                       role, fmt::format("{}.{}.{}.{}", address >> 24, (address >> 16) & 0xFFu, (address >> 8) & 0xFFu, address & 0xFFu)));
}

}  // namespace peha::mfb

namespace peha::mfb {

std::vector<io::UdpEndpoint> board_endpoints(const LinkConfig& link, const std::vector<io::UdpEndpoint>& given) {
  const std::size_t n = link.boards.size();
  if (given.size() == n) return given;
  if (given.size() != 1) {
    throw std::invalid_argument(fmt::format("--backend: the scenario has {} board(s); expected {} address(es) (udp://A:P,udp://B:Q,...) "
                                            "or one (board i at its port + i), found {}",
                                            n, n, given.size()));
  }
  std::vector<io::UdpEndpoint> out;
  for (std::size_t i = 0; i < n; ++i) {
    if (given[0].port + i > 65535) throw std::invalid_argument(fmt::format("--backend: port {} + {} is beyond 65535", given[0].port, i));
    out.push_back({given[0].address, static_cast<std::uint16_t>(given[0].port + i)});
  }
  return out;
}

}  // namespace peha::mfb
