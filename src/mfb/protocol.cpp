#include "peha/mfb/protocol.hpp"

#include <sodium.h>

namespace peha::mfb {
namespace {

// libsodium picks its fastest implementations in sodium_init(); everything here works before it
// too, so a static initialiser is enough (it is idempotent and thread-safe).
[[maybe_unused]] const int kSodiumReady = sodium_init();

// ---- CRC-32C ------------------------------------------------------------------------------------

constexpr std::uint32_t kCrc32cPolynomial = 0x82F63B78;  // 0x1EDC6F41 bit-reversed

constexpr std::array<std::uint32_t, 256> make_crc32c_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? (c >> 1) ^ kCrc32cPolynomial : c >> 1;
    table[i] = c;
  }
  return table;
}

constexpr std::array<std::uint32_t, 256> kCrc32cTable = make_crc32c_table();

// ---- little-endian byte access (no struct copies: the layout is the byte table, not the ABI) ---

void put_u8(std::uint8_t* p, std::size_t at, std::uint8_t v) { p[at] = v; }
void put_u16(std::uint8_t* p, std::size_t at, std::uint16_t v) {
  p[at] = static_cast<std::uint8_t>(v);
  p[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(std::uint8_t* p, std::size_t at, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i) p[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_u64(std::uint8_t* p, std::size_t at, std::uint64_t v) {
  for (std::size_t i = 0; i < 8; ++i) p[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::uint16_t get_u16(const std::uint8_t* p, std::size_t at) {
  return static_cast<std::uint16_t>(p[at] | (p[at + 1] << 8));
}
std::uint32_t get_u32(const std::uint8_t* p, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::uint32_t{p[at + i]} << (8 * i);
  return v;
}
std::uint64_t get_u64(const std::uint8_t* p, std::size_t at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i) v |= std::uint64_t{p[at + i]} << (8 * i);
  return v;
}

// ---- shared header and trailer ----------------------------------------------------------------

void put_header(std::uint8_t* p, PacketType type, std::size_t payload_size, std::uint32_t session,
                std::uint32_t sequence) {
  put_u32(p, kMagicOffset, kMagic);
  put_u8(p, kVersionOffset, kProtocolVersion);
  put_u8(p, kTypeOffset, static_cast<std::uint8_t>(type));
  put_u16(p, kPayloadLengthOffset, static_cast<std::uint16_t>(payload_size));
  put_u32(p, kSessionOffset, session);
  put_u32(p, kSequenceOffset, sequence);
}

/// Writes the trailer of a `size`-byte packet: the CRC of everything before it, then the MAC of
/// everything before that.
void put_trailer(std::uint8_t* p, std::size_t size, const LinkKey& key) {
  const std::size_t crc_at = size - kTrailerSize;
  put_u32(p, crc_at, crc32c(p, crc_at));
  const std::array<std::uint8_t, kMacSize> mac = packet_mac(key, p, size - kMacSize);
  for (std::size_t i = 0; i < kMacSize; ++i) p[size - kMacSize + i] = mac[i];
}

/// Every check that does not depend on the payload's content, in `ParseError`'s order.
ParseError check_frame(std::span<const std::uint8_t> in, PacketType type, std::size_t payload_size, const LinkKey& key) {
  const std::size_t packet_size = kHeaderSize + payload_size + kTrailerSize;
  if (in.size() < kHeaderSize) return ParseError::kTooShort;
  const std::uint8_t* p = in.data();
  if (get_u32(p, kMagicOffset) != kMagic) return ParseError::kBadMagic;
  if (p[kVersionOffset] != kProtocolVersion) return ParseError::kBadVersion;
  if (p[kTypeOffset] != static_cast<std::uint8_t>(type)) return ParseError::kWrongType;
  if (get_u16(p, kPayloadLengthOffset) != payload_size) return ParseError::kBadLength;
  if (in.size() < packet_size) return ParseError::kTooShort;
  if (in.size() > packet_size) return ParseError::kTooLong;
  const std::size_t crc_at = packet_size - kTrailerSize;
  if (get_u32(p, crc_at) != crc32c(p, crc_at)) return ParseError::kBadCrc;
  const std::array<std::uint8_t, kMacSize> mac = packet_mac(key, p, packet_size - kMacSize);
  if (sodium_memcmp(mac.data(), p + packet_size - kMacSize, kMacSize) != 0) return ParseError::kBadMac;
  return ParseError::kOk;
}

// ---- stream acceptance, shared by both filters -------------------------------------------------

Verdict count(ReceiveCounters& c, Verdict v) {
  switch (v) {
    case Verdict::kAccept: ++c.accepted; break;
    case Verdict::kForeignSource: ++c.foreign_source; break;
    case Verdict::kForeignSession: ++c.foreign_session; break;
    case Verdict::kDuplicate: ++c.duplicate; break;
    case Verdict::kStale: ++c.stale; break;
    case Verdict::kMalformed: ++c.malformed; break;
    case Verdict::kUnauthenticated: ++c.unauthenticated; break;
    case Verdict::kUnknownSession: ++c.unknown_session; break;
    case Verdict::kHello: ++c.hellos; break;
  }
  return v;
}

/// Newest-only rule of one session: accepts `sequence` if there is no last one or it is newer,
/// counting the skipped numbers; updates the last sequence on acceptance.
Verdict judge_sequence(bool& have_last, std::uint32_t& last, std::uint32_t sequence,
                       ReceiveCounters& c) {
  if (have_last) {
    if (sequence == last) return count(c, Verdict::kDuplicate);
    if (!sequence_newer(sequence, last)) return count(c, Verdict::kStale);
    c.gaps += sequence - last - 1u;  // modulo 2^32, so right across the wrap
  }
  have_last = true;
  last = sequence;
  return count(c, Verdict::kAccept);
}

}  // namespace

const char* to_string(ParseError e) noexcept {
  switch (e) {
    case ParseError::kOk: return "ok";
    case ParseError::kTooShort: return "too short";
    case ParseError::kTooLong: return "too long";
    case ParseError::kBadMagic: return "bad magic";
    case ParseError::kBadVersion: return "bad version";
    case ParseError::kWrongType: return "wrong type";
    case ParseError::kBadLength: return "bad length";
    case ParseError::kBadCrc: return "bad crc";
    case ParseError::kBadMac: return "bad mac";
    case ParseError::kBadFlags: return "bad flags";
    case ParseError::kZeroSession: return "zero session";
  }
  return "unknown parse error";
}

const char* to_string(Verdict v) noexcept {
  switch (v) {
    case Verdict::kAccept: return "accept";
    case Verdict::kForeignSource: return "foreign source";
    case Verdict::kForeignSession: return "foreign session";
    case Verdict::kDuplicate: return "duplicate";
    case Verdict::kStale: return "stale";
    case Verdict::kMalformed: return "malformed";
    case Verdict::kUnauthenticated: return "unauthenticated";
    case Verdict::kUnknownSession: return "unknown session";
    case Verdict::kHello: return "hello";
  }
  return "unknown verdict";
}

std::uint32_t crc32c(const std::uint8_t* data, std::size_t size) noexcept {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) crc = (crc >> 8) ^ kCrc32cTable[(crc ^ data[i]) & 0xFFu];
  return crc ^ 0xFFFFFFFFu;
}

std::array<std::uint8_t, kMacSize> packet_mac(const LinkKey& key, const std::uint8_t* data, std::size_t size) noexcept {
  std::array<std::uint8_t, kMacSize> mac{};
  crypto_generichash(mac.data(), mac.size(), data, size, key.bytes.data(), key.bytes.size());
  return mac;
}

std::size_t encode(const CommandPacket& packet, const LinkKey& key, std::span<std::uint8_t> out) noexcept {
  if (out.size() < kCommandPacketSize) return 0;
  std::uint8_t* p = out.data();
  put_header(p, packet.type, kCommandPayloadSize, packet.session_id, packet.sequence);
  put_u64(p, kCommandHostTimeOffset, packet.host_time_ns);
  for (std::size_t i = 0; i < packet.da.size(); ++i) put_u16(p, kCommandDaOffset + 2 * i, packet.da[i]);
  put_u8(p, kCommandDigitalOutOffset, packet.digital_out);
  put_u8(p, kCommandFlagsOffset, packet.flags);
  put_u64(p, kCommandBoardNonceOffset, packet.board_nonce);
  put_trailer(p, kCommandPacketSize, key);
  return kCommandPacketSize;
}

std::size_t encode(const StatePacket& packet, const LinkKey& key, std::span<std::uint8_t> out) noexcept {
  if (out.size() < kStatePacketSize) return 0;
  std::uint8_t* p = out.data();
  put_header(p, PacketType::kState, kStatePayloadSize, packet.session_id, packet.sequence);
  put_u64(p, kStateEchoHostTimeOffset, packet.echo_host_time_ns);
  put_u64(p, kStateBoardTimeOffset, packet.board_time_ns);
  put_u32(p, kStateAckSequenceOffset, packet.ack_sequence);
  for (std::size_t i = 0; i < packet.ad.size(); ++i) put_u16(p, kStateAdOffset + 2 * i, packet.ad[i]);
  for (std::size_t i = 0; i < packet.encoder.size(); ++i) {
    put_u32(p, kStateEncoderOffset + 4 * i, static_cast<std::uint32_t>(packet.encoder[i]));
  }
  put_u8(p, kStateDigitalInOffset, packet.digital_in);
  put_u8(p, kStateStatusOffset, packet.status);
  put_u64(p, kStateBoardNonceOffset, packet.board_nonce);
  put_u32(p, kStateBootIdOffset, packet.boot_id);
  put_u16(p, kStateLimitVentedOffset, packet.limit_vented);
  put_u8(p, kStateLimitMotorOffOffset, packet.limit_motor_off);
  put_trailer(p, kStatePacketSize, key);
  return kStatePacketSize;
}

ParseError decode(std::span<const std::uint8_t> in, const LinkKey& key, CommandPacket& out) noexcept {
  // A hello has the command's layout: the frame is checked as whichever of the two the type says.
  const bool hello = in.size() > kTypeOffset && in[kTypeOffset] == static_cast<std::uint8_t>(PacketType::kHello);
  const PacketType type = hello ? PacketType::kHello : PacketType::kCommand;
  if (const ParseError e = check_frame(in, type, kCommandPayloadSize, key); e != ParseError::kOk) {
    return e;
  }
  const std::uint8_t* p = in.data();
  CommandPacket c;
  c.type = type;
  c.session_id = get_u32(p, kSessionOffset);
  c.sequence = get_u32(p, kSequenceOffset);
  c.host_time_ns = get_u64(p, kCommandHostTimeOffset);
  for (std::size_t i = 0; i < c.da.size(); ++i) c.da[i] = get_u16(p, kCommandDaOffset + 2 * i);
  c.digital_out = p[kCommandDigitalOutOffset];
  c.flags = p[kCommandFlagsOffset];
  c.board_nonce = get_u64(p, kCommandBoardNonceOffset);
  if ((c.flags & ~kCommandKnownFlags) != 0) return ParseError::kBadFlags;
  if (hello) {  // a hello drives nothing and names no board nonce
    unsigned any = c.digital_out | c.flags;
    for (const std::uint16_t d : c.da) any |= d;
    if (any != 0 || c.board_nonce != 0) return ParseError::kBadFlags;
  }
  if (c.session_id == 0) return ParseError::kZeroSession;
  out = c;
  return ParseError::kOk;
}

ParseError decode(std::span<const std::uint8_t> in, const LinkKey& key, StatePacket& out) noexcept {
  if (const ParseError e = check_frame(in, PacketType::kState, kStatePayloadSize, key); e != ParseError::kOk) {
    return e;
  }
  const std::uint8_t* p = in.data();
  StatePacket s;
  s.session_id = get_u32(p, kSessionOffset);
  s.sequence = get_u32(p, kSequenceOffset);
  s.echo_host_time_ns = get_u64(p, kStateEchoHostTimeOffset);
  s.board_time_ns = get_u64(p, kStateBoardTimeOffset);
  s.ack_sequence = get_u32(p, kStateAckSequenceOffset);
  for (std::size_t i = 0; i < s.ad.size(); ++i) s.ad[i] = get_u16(p, kStateAdOffset + 2 * i);
  for (std::size_t i = 0; i < s.encoder.size(); ++i) {
    s.encoder[i] = static_cast<std::int32_t>(get_u32(p, kStateEncoderOffset + 4 * i));
  }
  s.digital_in = p[kStateDigitalInOffset];
  s.status = p[kStateStatusOffset];
  s.board_nonce = get_u64(p, kStateBoardNonceOffset);
  s.boot_id = get_u32(p, kStateBootIdOffset);
  s.limit_vented = get_u16(p, kStateLimitVentedOffset);
  s.limit_motor_off = p[kStateLimitMotorOffOffset];
  if ((s.status & ~kStatusKnownBits) != 0) return ParseError::kBadFlags;
  if (s.session_id == 0) return ParseError::kZeroSession;
  out = s;
  return ParseError::kOk;
}

// ---- StateFilter --------------------------------------------------------------------------------

StateFilter::StateFilter(std::uint32_t session_id, const LinkKey& key) noexcept : key_(key), session_id_(session_id) {}

void StateFilter::reset(std::uint32_t session_id) noexcept { *this = StateFilter(session_id, key_); }

namespace {
/// The verdict for a datagram `decode` rejected.
Verdict rejected(ParseError e) { return e == ParseError::kBadMac ? Verdict::kUnauthenticated : Verdict::kMalformed; }
}  // namespace

Verdict StateFilter::accept(std::span<const std::uint8_t> datagram, bool from_board_address,
                            StatePacket& out) noexcept {
  if (!from_board_address) return count(counters_, Verdict::kForeignSource);
  StatePacket packet;
  if (const ParseError e = decode(datagram, key_, packet); e != ParseError::kOk) {
    last_error_ = e;
    return count(counters_, rejected(e));
  }
  if (packet.session_id != session_id_) return count(counters_, Verdict::kForeignSession);
  bool restart = false;
  if (have_last_ && packet.boot_id != boot_id_) {
    // Another boot of the board: one it replaced is history (late or replayed), a new one restarted
    // its sequence counter, so the newest-only rule starts over from its first packet.
    if (have_retired_boot_ && packet.boot_id == retired_boot_) return count(counters_, Verdict::kStale);
    restart = true;
  }
  bool have_last = have_last_ && !restart;
  std::uint32_t last = last_sequence_;
  const Verdict v = judge_sequence(have_last, last, packet.sequence, counters_);
  if (v == Verdict::kAccept) {
    if (restart) {
      retired_boot_ = boot_id_;
      have_retired_boot_ = true;
      ++counters_.reboots;
    }
    have_last_ = have_last;
    last_sequence_ = last;
    boot_id_ = packet.boot_id;
    out = packet;
  }
  return v;
}

// ---- CommandFilter ------------------------------------------------------------------------------

Verdict CommandFilter::accept(std::span<const std::uint8_t> datagram, const Source& from, CommandPacket& out) noexcept {
  CommandPacket packet;
  if (const ParseError e = decode(datagram, key_, packet); e != ParseError::kOk) {
    last_error_ = e;
    return count(counters_, rejected(e));
  }
  if (packet.type == PacketType::kHello) return count(counters_, Verdict::kHello);
  // The session belongs to the endpoint that opened it: nobody else is obeyed or answered.
  if (has_session_ && !(from == peer_)) return count(counters_, Verdict::kForeignSource);
  if (packet.session_id != session_id_) {
    if (has_session_) return count(counters_, Verdict::kForeignSession);
    // Adoption of a new session: its sequence starts a fresh baseline. (Re-adopting the released
    // session keeps that session's baseline, so the newest-only rule below still applies.)
    have_last_ = false;
  }
  const Verdict v = judge_sequence(have_last_, last_sequence_, packet.sequence, counters_);
  if (v == Verdict::kAccept) {
    session_id_ = packet.session_id;
    has_session_ = true;
    peer_ = from;
    out = packet;
  }
  return v;
}

// ---- OutputArming -------------------------------------------------------------------------------

void OutputArming::on_command(const CommandPacket& command) noexcept {
  if (command.session_id != session_id_) {  // a new host must make its own enable edge
    session_id_ = command.session_id;
    armed_ = false;
    seen_disable_ = false;
  }
  if ((command.flags & kCommandEnable) == 0) {
    armed_ = false;
    seen_disable_ = !estop_;  // the edge must start after the e-stop is released
    tripped_ = false;  // the host has acknowledged the trip
  } else if (!armed_ && seen_disable_ && !estop_ && command.board_nonce == token_ &&
             (!host_lost_ || (command.flags & kCommandOperatorArm) != 0)) {
    armed_ = true;
    host_lost_ = false;  // the operator armed the board again
  }
}

void OutputArming::on_watchdog() noexcept {
  if (armed_) host_lost_ = true;  // outputs were live and their host fell silent
  tripped_ = true;
  armed_ = false;
  seen_disable_ = false;
}

void OutputArming::set_estop(bool active) noexcept {
  estop_ = active;
  if (active) {
    armed_ = false;
    seen_disable_ = false;
  }
}

std::uint8_t OutputArming::status() const noexcept {
  std::uint8_t s = 0;
  if (tripped_) s |= kStatusWatchdogTripped;
  if (!outputs_enabled()) s |= kStatusOutputsSafe;
  if (estop_) s |= kStatusEstop;
  if (host_lost_) s |= kStatusHostLost;
  return s;
}

}  // namespace peha::mfb
