#pragma once
/// \file
/// The `mfb:` section of a scenario: how it runs on the multifunction board over UDP
/// (docs/mfb-protocol.md, docs/runtime.md), and the host's backend built from it.

#include "peha/config/reader.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/boards_backend.hpp"
#include "peha/mfb/udp_backend.hpp"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace peha::mfb {

/// Most boards one scenario may run on (one host socket and one emulator thread each).
inline constexpr int kMaxBoards = 8;

/// One board of a scenario: its channel map, its key and the io joints its map carries.
struct BoardLink {
  std::string name;                    ///< `boards[i].name` ("" for the single-board form)
  std::filesystem::path channel_map;   ///< resolved against the scenario's folder
  std::filesystem::path key_file;      ///< the board's key (its own `key_file:` or the section's)
  /// The io joints on this board, in io order (the channel map is read for these). Empty when the
  /// section was read without the io joints (`read_link_config(map)`).
  std::vector<std::string> joint_names;
};

struct LinkConfig {
  /// The first board's channel map and key file (the single-board form's `channel_map:` and
  /// `key_file:`): what a one-board experiment (E1, E4, E5) reads.
  std::filesystem::path channel_map;   ///< resolved against the scenario's folder
  /// The link's pre-shared key file (`key_file:`, resolved against the scenario's folder): 64 hex
  /// digits, readable by its owner only. Host and board read the same file (`load_link_key`).
  std::filesystem::path key_file;
  /// Every board, in the order of `boards:` (one entry for the single-board form). The watchdog,
  /// timeout and vent below hold for each board's link; the host's watchdog and the recovery ramp
  /// are the lifecycle supervisor's (the scenario's `lifecycle:`, runtime::read_lifecycle).
  std::vector<BoardLink> boards;
  double board_watchdog_s = 0.05;      ///< the board's: no command this long -> safe outputs
  double receive_timeout_s = 0.0008;   ///< how long a cycle waits for the board's reply
  double vent_s = 2.0;                 ///< the board's controlled venting after its watchdog fired
};

/// Reads an `mfb:` mapping (finishes it): either one board (`channel_map:`, `key_file:`) or several
/// (`boards:` - a list of `{name, channel_map, key_file}`, each key_file defaulting to the section's).
/// With `io_joints` (the scenario's io joints, in io order) the boards are checked against them:
/// a multi-board section's maps are read, and config::Error (file, field, expected vs found)
/// refuses a map that does not fit one board (more AD, DA or encoder channels than it has), a
/// map's joint that is no io joint, an io joint on no board or on two; each board gets its joints
/// (BoardLink::joint_names). A single-board section gets every io joint.
LinkConfig read_link_config(config::Map map, const std::vector<std::string>& io_joints = {});

/// Reads a link key file: 64 hex digits (the 32 key bytes), optionally surrounded by whitespace,
/// and `#` comment lines. Throws std::runtime_error naming the file and what is wrong: missing,
/// not a regular file, readable or writable by group or others (the fix: `chmod 600 <file>`),
/// not exactly 64 hex digits, or of low entropy (fewer than kMinDistinctKeyBytes distinct byte
/// values: all zero, one repeated byte, a short pattern).
LinkKey load_link_key(const std::filesystem::path& path);

/// A key of fewer distinct byte values is refused: 32 random bytes have 8 or fewer with a chance
/// below 1e-20, while a typed pattern ("0000...", "abab...", "0123...0123") has few.
inline constexpr int kMinDistinctKeyBytes = 8;

/// `peha keygen`: writes a fresh key (32 bytes from libsodium's randombytes_buf, the OS's entropy)
/// to `path` in load_link_key's format, created with mode 0600. Refuses (std::runtime_error naming
/// the file) to overwrite anything that exists: a board's key is replaced on purpose, not by a
/// typo.
void write_new_link_key(const std::filesystem::path& path);

/// True for the development key the repository ships (configs/mfb/dev_link.key): it is public.
bool is_development_key(const LinkKey& key) noexcept;

/// Refuses (std::runtime_error naming `key_file`, the address and `peha keygen`) the development
/// key for a link whose `address` (IPv4, host byte order) is not loopback (127.0.0.0/8): a key
/// everyone has authenticates nothing on a network. `role` names the endpoint ("board", "bind").
void require_private_key_off_loopback(const LinkKey& key, std::uint32_t address, const std::string& role);

/// Where each board of `link` is, from --backend's addresses: one per board, in the order of
/// `boards:`, or a single address for all of them - board i at its port + i. Throws
/// std::invalid_argument naming the count expected and found otherwise.
std::vector<io::UdpEndpoint> board_endpoints(const LinkConfig& link, const std::vector<io::UdpEndpoint>& given);

}  // namespace peha::mfb
