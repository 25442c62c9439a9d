#pragma once
/// \file
/// The `mfb:` section of a scenario: how it runs on the multifunction board over UDP
/// (docs/mfb-protocol.md, docs/runtime.md), and the host's backend built from it.

#include "peha/config/reader.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/udp_backend.hpp"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace peha::mfb {

struct LinkConfig {
  std::filesystem::path channel_map;   ///< resolved against the scenario's folder
  /// The link's pre-shared key file (`key_file:`, resolved against the scenario's folder): 64 hex
  /// digits, readable by its owner only. Host and board read the same file (`load_link_key`).
  std::filesystem::path key_file;
  double board_watchdog_s = 0.05;      ///< the board's: no command this long -> safe outputs
  double host_watchdog_s = 0.02;       ///< the host's: no sample this long -> fault
  double receive_timeout_s = 0.0008;   ///< how long a cycle waits for the board's reply
  double vent_s = 2.0;                 ///< the board's controlled venting after its watchdog fired
  double recovery_ramp_s = 1.0;        ///< after a recovery, commands ramp from safe to the controller's
};

/// Reads an `mfb:` mapping (finishes it).
LinkConfig read_link_config(config::Map map);

/// Reads a link key file: 64 hex digits (the 32 key bytes), optionally surrounded by whitespace,
/// and `#` comment lines. Throws std::runtime_error naming the file and what is wrong: missing,
/// not a regular file, readable or writable by group or others (the fix: `chmod 600 <file>`),
/// not exactly 64 hex digits, or all zero.
LinkKey load_link_key(const std::filesystem::path& path);

/// The host's UdpBackend for the board at `board`, for joints `joint_names` (channel map and key
/// from `link`), not yet connected. Throws config::Error on a bad channel map, std::runtime_error
/// on a bad key file or a board no interface of this machine reaches.
std::unique_ptr<UdpBackend> make_board_backend(const LinkConfig& link, const io::UdpEndpoint& board, double period_s,
                                               const std::vector<std::string>& joint_names);

}  // namespace peha::mfb
