#pragma once
/// \file
/// The MFB wire protocol: the UDP datagrams between peha's real-time PC and the multifunction board
/// (16 AD channels, 8 DA channels, 8 digital lines each way, 8 quadrature encoders).
///
/// Pure code, no sockets. Packets are serialised byte by byte in little-endian order (never by
/// copying structs), so the layout does not depend on the compiler or the CPU. Every packet is
///
///     header (16 bytes) | type-specific payload | CRC-32C (4 bytes) | MAC (16 bytes)
///
/// The CRC covers everything before it and tells a noisy link; the MAC (keyed BLAKE2b from
/// libsodium, 16 bytes, with the 32-byte pre-shared `LinkKey`) covers everything before it, CRC
/// included, and tells who may speak: without the key no packet is accepted.
///
/// The byte tables, the session, sequence, timing and watchdog rules are in `docs/mfb-protocol.md`;
/// the offsets below (`kCommand...Offset`, `kState...Offset`) are the same table in code.
///
/// Receiving is two steps: `decode` checks one datagram on its own (size, magic, version, type,
/// length, CRC, MAC, flag bits, session != 0); `StateFilter` (host) and `CommandFilter` (board)
/// then judge it against the stream (source, session, newest-only) and count what they drop.
///
/// Everything here is `noexcept` and allocates nothing: it runs inside the control loop.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace peha::mfb {

// ---------------------------------------------------------------------------------------------
// Constants

/// First four bytes of every packet: 'M','F','B','1' on the wire (read as a little-endian u32).
inline constexpr std::uint32_t kMagic = 0x3142464D;
/// Layout version. Any change to a layout or to the meaning of a field or bit bumps it; receivers
/// accept exactly this version and reject every other (`ParseError::kBadVersion`).
inline constexpr std::uint8_t kProtocolVersion = 5;

inline constexpr std::size_t kKeySize = 32;  ///< bytes of the pre-shared link key
inline constexpr std::size_t kMacSize = 16;  ///< bytes of the MAC that ends every packet

/// The pre-shared key of one host-board link (docs/mfb-protocol.md#authentication): 32 secret
/// bytes, read from the key file the `mfb:` section names (`mfb::load_link_key`), never from YAML.
struct LinkKey {
  std::array<std::uint8_t, kKeySize> bytes{};
};

inline constexpr int kAdChannels = 16;       ///< 16-bit analogue inputs
inline constexpr int kDaChannels = 8;        ///< 16-bit analogue outputs
inline constexpr int kEncoderChannels = 8;   ///< quadrature decoders, 32-bit signed counts

/// `CommandPacket::flags` bit 0: outputs enabled. Outputs follow the command only while this is
/// set and the board is armed (see `OutputArming`); otherwise the board holds its safe outputs.
inline constexpr std::uint8_t kCommandEnable = 0x01;
/// `CommandPacket::flags` bit 1: the operator arms the board after a host loss. While the board
/// reports `kStatusHostLost`, an enable edge arms it only with this bit set (see `OutputArming`).
inline constexpr std::uint8_t kCommandOperatorArm = 0x02;
/// Every flag bit this version defines; a command with any other bit set is rejected (`kBadFlags`).
inline constexpr std::uint8_t kCommandKnownFlags = kCommandEnable | kCommandOperatorArm;

/// `StatePacket::status` bits.
/// The watchdog fired (no accepted command for `watchdog_ms`). Latched until the host acknowledges
/// with a command whose enable flag is clear.
inline constexpr std::uint8_t kStatusWatchdogTripped = 0x01;
/// The board holds its safe outputs (safe DA codes, all digital outputs low) instead of the
/// command's. Set whenever the outputs are not armed, for whatever reason.
inline constexpr std::uint8_t kStatusOutputsSafe = 0x02;
/// The hardware emergency-stop input is active.
inline constexpr std::uint8_t kStatusEstop = 0x04;
/// The board holds no session: the next valid command of any session will be adopted.
inline constexpr std::uint8_t kStatusNoSession = 0x08;
/// The board's watchdog fired while its outputs were armed: the host that drove them is gone.
/// Latched until an enable edge with `kCommandOperatorArm` arms the board again; until then no
/// session, new or old, can arm it without that bit.
inline constexpr std::uint8_t kStatusHostLost = 0x10;
/// Every status bit this version defines; a state packet with any other bit set is rejected.
inline constexpr std::uint8_t kStatusKnownBits =
    kStatusWatchdogTripped | kStatusOutputsSafe | kStatusEstop | kStatusNoSession | kStatusHostLost;

/// `PacketType` on the wire (header byte 5).
enum class PacketType : std::uint8_t {
  kCommand = 1,  ///< host -> board
  kState = 2,    ///< board -> host
  kHello = 3,    ///< host -> board: opens a session (a command's layout, outputs, flags and nonce zero)
};

// ---------------------------------------------------------------------------------------------
// Packets (the decoded values; their wire layout is the byte table in docs/mfb-protocol.md)

/// Host -> board: a command, one per control period, or a hello (`type`), which asks the board for
/// its nonce of a session (docs/mfb-protocol.md#the-handshake).
struct CommandPacket {
  /// `kCommand` or `kHello` (a hello's outputs, flags and `board_nonce` are all zero).
  PacketType type = PacketType::kCommand;
  /// The host's nonce of the session: random, nonzero, chosen per host session.
  std::uint32_t session_id = 0;
  /// +1 per command within a session; wraps from 2^32-1 to 0.
  std::uint32_t sequence = 0;
  /// Host monotonic clock when sent [ns]; the board echoes it back (`StatePacket::echo_host_time_ns`)
  /// so the host can measure the round trip with its own clock.
  std::uint64_t host_time_ns = 0;
  /// DA output codes 0..65535 (the board's channel map turns them into volts).
  std::array<std::uint16_t, kDaChannels> da{};
  /// Digital output lines, bit i = line i, 1 = high.
  std::uint8_t digital_out = 0;
  /// `kCommandEnable`, `kCommandOperatorArm`; every other bit must be 0.
  std::uint8_t flags = 0;
  /// The board's nonce of the session (`StatePacket::board_nonce` of its answer to the host's
  /// hello). The board opens a session only for a command carrying the nonce it answered to this
  /// host nonce and endpoint in this boot, so a recorded session replayed later is never obeyed.
  std::uint64_t board_nonce = 0;

  bool operator==(const CommandPacket&) const = default;
};

/// Board -> host, one per accepted command, and one per board period while no command arrives.
struct StatePacket {
  /// The session the board adopted last (also while it holds none, see `kStatusNoSession`).
  std::uint32_t session_id = 0;
  /// The board's own counter, +1 per state packet sent; wraps from 2^32-1 to 0.
  std::uint32_t sequence = 0;
  /// `sequence` of the last command the board accepted (0 before the first).
  std::uint32_t ack_sequence = 0;
  /// `host_time_ns` of that command [ns, host clock]: round trip = host now - this.
  std::uint64_t echo_host_time_ns = 0;
  /// Board clock when the inputs were sampled [ns, board clock, not synchronised to the host].
  std::uint64_t board_time_ns = 0;
  /// AD input codes 0..65535.
  std::array<std::uint16_t, kAdChannels> ad{};
  /// Encoder positions [counts], two's complement, wrapping at +-2^31.
  std::array<std::int32_t, kEncoderChannels> encoder{};
  /// Digital input lines, bit i = line i, 1 = high.
  std::uint8_t digital_in = 0;
  /// `kStatus...` bits; every other bit must be 0.
  std::uint8_t status = 0;
  /// The board's nonce of this session (the answer to a hello, then every state of the session);
  /// 0: the board holds no session of this host nonce (it restarted, or never opened one) and the
  /// host must say hello again.
  std::uint64_t board_nonce = 0;
  /// The board's boot id: drawn at random (nonzero) at each power-on and constant until the next.
  /// A state packet of the host's session with another boot id than the ones before it tells the
  /// host that the board restarted (its sequence counter, session and arming started over).
  std::uint32_t boot_id = 0;
  /// The board's own limits acting now (docs/safety.md#the-boards-own-limits), whatever the host
  /// commands: bit 2 x joint + muscle (0 agonist, 1 antagonist) of each muscle a board limit vents
  /// (its load cell's ceiling, or its joint's range), in the order of the board's channel map.
  std::uint16_t limit_vented = 0;
  /// Bit j: joint j's motor cut by the board's range (the joint is, or is about to be, outside it).
  std::uint8_t limit_motor_off = 0;

  bool operator==(const StatePacket&) const = default;
};

// ---------------------------------------------------------------------------------------------
// Layout (byte offsets from the start of the datagram; all fields little-endian)

inline constexpr std::size_t kHeaderSize = 16;  ///< magic, version, type, length, session, sequence
inline constexpr std::size_t kCrcSize = 4;      ///< CRC-32C after the payload
inline constexpr std::size_t kTrailerSize = kCrcSize + kMacSize;  ///< CRC then MAC

inline constexpr std::size_t kMagicOffset = 0;          ///< u32
inline constexpr std::size_t kVersionOffset = 4;        ///< u8
inline constexpr std::size_t kTypeOffset = 5;           ///< u8, `PacketType`
inline constexpr std::size_t kPayloadLengthOffset = 6;  ///< u16, bytes between header and CRC
inline constexpr std::size_t kSessionOffset = 8;        ///< u32
inline constexpr std::size_t kSequenceOffset = 12;      ///< u32

inline constexpr std::size_t kCommandHostTimeOffset = 16;    ///< u64
inline constexpr std::size_t kCommandDaOffset = 24;          ///< u16 x 8
inline constexpr std::size_t kCommandDigitalOutOffset = 40;  ///< u8
inline constexpr std::size_t kCommandFlagsOffset = 41;       ///< u8
inline constexpr std::size_t kCommandBoardNonceOffset = 42;  ///< u64
/// Bytes between the command's header and its CRC (the header's length field).
inline constexpr std::size_t kCommandPayloadSize = 34;
/// Exact size of a command datagram.
inline constexpr std::size_t kCommandPacketSize = kHeaderSize + kCommandPayloadSize + kTrailerSize;  // 70

inline constexpr std::size_t kStateEchoHostTimeOffset = 16;  ///< u64
inline constexpr std::size_t kStateBoardTimeOffset = 24;     ///< u64
inline constexpr std::size_t kStateAckSequenceOffset = 32;   ///< u32
inline constexpr std::size_t kStateAdOffset = 36;            ///< u16 x 16
inline constexpr std::size_t kStateEncoderOffset = 68;       ///< i32 x 8
inline constexpr std::size_t kStateDigitalInOffset = 100;    ///< u8
inline constexpr std::size_t kStateStatusOffset = 101;       ///< u8
inline constexpr std::size_t kStateBoardNonceOffset = 102;   ///< u64
inline constexpr std::size_t kStateBootIdOffset = 110;       ///< u32
inline constexpr std::size_t kStateLimitVentedOffset = 114;  ///< u16
inline constexpr std::size_t kStateLimitMotorOffOffset = 116;  ///< u8
/// Bytes between the state's header and its CRC (the header's length field).
inline constexpr std::size_t kStatePayloadSize = 101;
/// Exact size of a state datagram.
inline constexpr std::size_t kStatePacketSize = kHeaderSize + kStatePayloadSize + kTrailerSize;  // 137

/// Largest datagram of this version: a receive buffer of this size holds any valid packet (use one
/// byte more to tell "too long" from "exactly the largest").
inline constexpr std::size_t kMaxPacketSize =
    kCommandPacketSize > kStatePacketSize ? kCommandPacketSize : kStatePacketSize;

// ---------------------------------------------------------------------------------------------
// Encoding and decoding

/// Why `decode` rejected a datagram. The checks run in this order, so a packet of another
/// version reports `kBadVersion` even though its size differs too.
enum class ParseError : std::uint8_t {
  kOk,          ///< accepted
  kTooShort,    ///< fewer bytes than the header, or than the packet type's exact size
  kTooLong,     ///< more bytes than the packet type's exact size
  kBadMagic,    ///< first four bytes are not 'MFB1'
  kBadVersion,  ///< version byte != `kProtocolVersion`
  kWrongType,   ///< type byte is not the type the caller decodes
  kBadLength,   ///< header length field != the type's payload size
  kBadCrc,      ///< CRC-32C does not match (a noisy link)
  kBadMac,      ///< intact, but the MAC does not match: another key, or a forgery
  kBadFlags,    ///< unknown bits in `CommandPacket::flags` or `StatePacket::status`; a hello with outputs
  kZeroSession, ///< session id 0 (never valid; 0 means "none")
};

/// Short lower-case name of `e` ("bad crc"); never null.
const char* to_string(ParseError e) noexcept;

/// CRC-32C (Castagnoli; reflected polynomial 0x82F63B78, initial value and final XOR 0xFFFFFFFF),
/// table-driven. The check value of the ASCII bytes "123456789" is 0xE3069283.
std::uint32_t crc32c(const std::uint8_t* data, std::size_t size) noexcept;

/// The 16-byte MAC of `data` under `key`: keyed BLAKE2b (libsodium `crypto_generichash`).
std::array<std::uint8_t, kMacSize> packet_mac(const LinkKey& key, const std::uint8_t* data, std::size_t size) noexcept;

/// Serialises `packet` into the first `kCommandPacketSize` bytes of `out`, CRC and MAC (under
/// `key`) included. Returns the bytes written, or 0 (writing nothing) if `out` is too small. Does
/// not validate: fields the receiver rejects (session 0, unknown flags) are written as they are.
std::size_t encode(const CommandPacket& packet, const LinkKey& key, std::span<std::uint8_t> out) noexcept;
/// Same for a state packet (`kStatePacketSize` bytes).
std::size_t encode(const StatePacket& packet, const LinkKey& key, std::span<std::uint8_t> out) noexcept;

/// Parses one whole datagram as a command or a hello (`out.type`), its MAC checked under `key` (in
/// constant time). `out` is written only when the result is `kOk`.
ParseError decode(std::span<const std::uint8_t> in, const LinkKey& key, CommandPacket& out) noexcept;
/// Parses one whole datagram as a state packet. `out` is written only when the result is `kOk`.
ParseError decode(std::span<const std::uint8_t> in, const LinkKey& key, StatePacket& out) noexcept;

/// Serial-number order of 32-bit sequence numbers (RFC 1982): true if `a` comes after `b`, i.e.
/// `a - b` modulo 2^32 is in [1, 2^31 - 1]. So 0 is newer than 0xFFFFFFFF, and a number exactly
/// 2^31 ahead counts as older.
constexpr bool sequence_newer(std::uint32_t a, std::uint32_t b) noexcept {
  const std::uint32_t d = a - b;
  return d != 0 && d < 0x80000000u;
}

// ---------------------------------------------------------------------------------------------
// Stream acceptance

/// What a filter decided about one datagram. Everything but `kAccept` is dropped and counted.
enum class Verdict : std::uint8_t {
  kAccept,          ///< newest packet of the current session from the right peer
  kForeignSource,   ///< came from another address and port than the board (host) or than the
                    ///< endpoint that opened the session (board)
  kForeignSession,  ///< valid, but another session
  kDuplicate,       ///< same sequence as the last accepted packet
  kStale,           ///< older than the last accepted packet (reordered or late)
  kMalformed,       ///< `decode` rejected it (`last_error()` says why), except for its MAC
  kUnauthenticated, ///< intact but its MAC is wrong (`ParseError::kBadMac`): another key or a forgery
  kUnknownSession,  ///< (board) a command of no session a handshake of this boot opened: a replay
  kHello,           ///< (board) a hello, answered with the board's nonce; no session changed
};

/// Short lower-case name of `v` ("foreign session"); never null.
const char* to_string(Verdict v) noexcept;

/// What a filter has seen since construction or its last `reset`. Every datagram given to
/// `accept` increments exactly one of the verdict counters.
struct ReceiveCounters {
  std::uint64_t accepted = 0;
  std::uint64_t foreign_source = 0;
  std::uint64_t foreign_session = 0;
  std::uint64_t duplicate = 0;
  std::uint64_t stale = 0;
  std::uint64_t malformed = 0;
  std::uint64_t unauthenticated = 0;
  std::uint64_t unknown_session = 0;  ///< (board) commands of no session opened by a handshake: replays
  std::uint64_t hellos = 0;           ///< (board) hellos answered
  /// Sequence numbers skipped between consecutive accepted packets (accepting 7 after 4 adds 2).
  /// A skipped packet that arrives later is dropped as stale and stays counted here.
  std::uint64_t gaps = 0;
  /// Board restarts seen (host only): accepted packets of the session whose boot id differed from
  /// the one before (`StateFilter`). Not a verdict: such a packet is also counted as accepted.
  std::uint64_t reboots = 0;
};

/// Where a datagram came from: IPv4 address and UDP port, host byte order.
struct Source {
  std::uint32_t address = 0;
  std::uint16_t port = 0;
  bool operator==(const Source&) const = default;
};

/// Host side: accepts the state packets of one session, newest only.
///
/// A datagram is accepted only if it came from the configured board address, decodes with an
/// intact MAC under the link key, carries the filter's session and its sequence is newer
/// (`sequence_newer`) than the last accepted one. The first valid packet of the session is
/// accepted whatever its sequence: the board's counter runs across sessions. A packet of the session
/// with another boot id than the last accepted one is a board restart: the board's counter started
/// over, so it is accepted as a new baseline and counted in `ReceiveCounters::reboots`; packets of
/// the boot it replaced are stale from then on (a late or replayed packet cannot switch back). No
/// allocation, no exceptions.
class StateFilter {
 public:
  /// Filters for `session_id`, the session the host puts in its commands (nonzero; with 0 every
  /// valid packet is judged `kForeignSession`), with the link's `key`.
  StateFilter(std::uint32_t session_id, const LinkKey& key) noexcept;

  /// Parses `datagram` and judges it. `from_board_address` is whether the datagram's source
  /// address and port are the configured board's (if not, it is not even parsed). On `kAccept`
  /// fills `out`; otherwise `out` is untouched.
  Verdict accept(std::span<const std::uint8_t> datagram, bool from_board_address,
                 StatePacket& out) noexcept;

  const ReceiveCounters& counters() const noexcept { return counters_; }
  /// Why the last `kMalformed` datagram was rejected (`kOk` if none was).
  ParseError last_error() const noexcept { return last_error_; }
  std::uint32_t session_id() const noexcept { return session_id_; }
  /// Boot id of the last accepted packet (0 before the first).
  std::uint32_t boot_id() const noexcept { return boot_id_; }

  /// Starts over for a new session: forgets the last sequence and boot, zeroes the counters.
  void reset(std::uint32_t session_id) noexcept;

 private:
  LinkKey key_;
  std::uint32_t session_id_;
  bool have_last_ = false;
  std::uint32_t last_sequence_ = 0;
  std::uint32_t boot_id_ = 0;
  bool have_retired_boot_ = false;
  std::uint32_t retired_boot_ = 0;  ///< the boot the last restart replaced
  ReceiveCounters counters_{};
  ParseError last_error_ = ParseError::kOk;
};

/// Board side: adopts one host's session and accepts its commands, newest only. A model of the
/// board core's session rules (firmware/core/mfb_board.c) for the fuzzer and the tests, without
/// the handshake: it adopts any command's session, where the core opens only a session whose board
/// nonce it answered to a hello in this boot (docs/mfb-protocol.md#the-handshake). Hellos are
/// counted (`kHello`) and change nothing.
///
/// Session rule: the board holds at most one session. Without one (after power-on, `reset`, or
/// `release` when its watchdog fired) the next command that decodes is adopted and accepted,
/// whatever its session and sequence — except that a command of the session just released must
/// still be newer than that session's last accepted command (a late packet cannot revive an old
/// command). While holding a session, commands of any other session are dropped as
/// `kForeignSession`; so a second host can take over only after the first has been silent for the
/// watchdog time. Within the session the rules are `StateFilter`'s: duplicates and older sequences
/// are dropped, skipped sequences counted as gaps. Only commands with an intact MAC under the link
/// key count at all (others: `kMalformed` / `kUnauthenticated`, never adopted, never feeding the
/// watchdog). The session belongs to the endpoint (address and port) whose command opened it:
/// while it is held, commands from any other endpoint are dropped as `kForeignSource`, whatever
/// their session and sequence. The board replies to that endpoint.
class CommandFilter {
 public:
  /// Power-on state: no session; commands are checked under `key`.
  explicit CommandFilter(const LinkKey& key) noexcept : key_(key) {}

  /// Parses `datagram`, which came from `from`, and judges it. On `kAccept` fills `out` (and holds
  /// `out.session_id` for `from`); otherwise `out` is untouched.
  Verdict accept(std::span<const std::uint8_t> datagram, const Source& from, CommandPacket& out) noexcept;

  /// The board's watchdog fired: let go of the session, so that the next valid command of any
  /// session is adopted. `session_id()` keeps the released session for the state packets.
  void release() noexcept { has_session_ = false; }

  /// True while a session is held (false: the board reports `kStatusNoSession`).
  bool has_session() const noexcept { return has_session_; }
  /// The session held or last held (0 before the first adoption).
  std::uint32_t session_id() const noexcept { return session_id_; }
  /// The endpoint that opened the session held or last held.
  const Source& peer() const noexcept { return peer_; }
  const ReceiveCounters& counters() const noexcept { return counters_; }
  /// Why the last `kMalformed` datagram was rejected (`kOk` if none was).
  ParseError last_error() const noexcept { return last_error_; }

  /// Back to the power-on state: no session, no last sequence, counters zeroed.
  void reset() noexcept { *this = CommandFilter(key_); }

 private:
  LinkKey key_;
  Source peer_{};
  bool has_session_ = false;
  std::uint32_t session_id_ = 0;
  bool have_last_ = false;
  std::uint32_t last_sequence_ = 0;
  std::uint32_t boot_id_ = 0;
  bool have_retired_boot_ = false;
  std::uint32_t retired_boot_ = 0;  ///< the boot the last restart replaced
  ReceiveCounters counters_{};
  ParseError last_error_ = ParseError::kOk;
};

/// Board side: when the outputs may follow the commands (the re-arm rule), and the status bits
/// that report it.
///
/// Outputs are armed only by an enable edge: an accepted command with `kCommandEnable` set and the
/// session's board nonce that follows an accepted command of the same session with enable
/// clear. Power-on, a new session, the watchdog and the emergency stop all disarm and need a new
/// edge; while disarmed the board holds its safe outputs (`kStatusOutputsSafe`). A watchdog trip
/// also latches `kStatusWatchdogTripped` until the host acknowledges it with a command whose enable
/// flag is clear; so a host that was only stalled cannot resume driving the outputs without first
/// noticing the trip. A trip while armed is a host loss: `kStatusHostLost` latches, and only an
/// edge that also carries `kCommandOperatorArm` (the operator's arming) arms again and clears it.
class OutputArming {
 public:
  /// Call with every command `CommandFilter` accepted, before applying its outputs.
  void on_command(const CommandPacket& command) noexcept;
  /// Call when the watchdog fires (no accepted command for `watchdog_ms`).
  void on_watchdog() noexcept;
  /// The board nonce an enable edge must carry from now on: the session's, fresh per handshake
  /// (0, the power-on value, is for tests of the rules alone).
  void set_token(std::uint64_t token) noexcept { token_ = token; }
  std::uint64_t token() const noexcept { return token_; }
  /// Call every board period with the level of the emergency-stop input.
  void set_estop(bool active) noexcept;

  /// True if the outputs follow the last accepted command; false: safe outputs.
  bool outputs_enabled() const noexcept { return armed_ && !estop_; }
  /// `kStatusWatchdogTripped`, `kStatusOutputsSafe`, `kStatusEstop`, `kStatusHostLost` as they apply now.
  /// (`kStatusNoSession` comes from `CommandFilter::has_session`.)
  std::uint8_t status() const noexcept;

 private:
  std::uint32_t session_id_ = 0;
  bool seen_disable_ = false;  // an accepted command with enable clear since the last disarm
  bool armed_ = false;
  bool tripped_ = false;
  bool estop_ = false;
  bool host_lost_ = false;
  std::uint64_t token_ = 0;
};

}  // namespace peha::mfb
