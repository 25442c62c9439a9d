// libFuzzer target for the MFB wire protocol (include/peha/mfb/protocol.hpp).
//
// Each input is used three ways:
//  1. as one datagram, given to both decoders and both filters;
//  2. the same bytes with the CRC recomputed (the MAC then fails: a forgery without the key), and
//     with CRC and MAC recomputed under the fuzz key, so that mutations reach the checks behind
//     them (flag bits, zero session) and the re-encode invariant sees many valid packets;
//  3. as a script of 8-byte records, each making one packet with `encode` (fuzzer-chosen session,
//     sequence step, flags, source endpoint, arm token, key, optional bit flip) for the host's
//     StateFilter or the board's CommandFilter + OutputArming; every verdict is checked against a
//     reference model written from the rules in docs/mfb-protocol.md.
// Invariants: never crash (ASan/UBSan); decode kOk => re-encoding gives the identical bytes;
// decode leaves its output untouched on error; every datagram lands in exactly one counter.
//
// Build and run (see docs/mfb-protocol.md, "Fuzzing"):
//   clang++-14 -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -I include
//       src/mfb/protocol.cpp fuzz/mfb_packet_fuzz.cpp -lsodium -o /tmp/mfb_fuzz
//   mkdir -p /tmp/mfb_corpus && /tmp/mfb_fuzz -max_total_time=120 /tmp/mfb_corpus fuzz/corpus/mfb_packet
#include "peha/mfb/protocol.hpp"
#include "fuzz_key.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace {

using namespace peha::mfb;

#define FUZZ_CHECK(cond)                                                         \
  do {                                                                           \
    if (!(cond)) {                                                               \
      std::fprintf(stderr, "%s:%d: invariant failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                              \
    }                                                                            \
  } while (0)

const LinkKey kKey = fuzz_key();

std::uint64_t total(const ReceiveCounters& c) {
  return c.accepted + c.foreign_source + c.foreign_session + c.duplicate + c.stale + c.malformed + c.unauthenticated;
}

/// The verdict of a filter for a datagram `decode` rejected with `e`.
Verdict rejected(ParseError e) { return e == ParseError::kBadMac ? Verdict::kUnauthenticated : Verdict::kMalformed; }

template <typename Packet>
Packet sentinel() {
  Packet p;
  p.session_id = 0xDEADBEEF;
  p.sequence = 0x5A5A5A5A;
  return p;
}

/// Decodes `in` as `Packet`; checks the output is untouched on error and that a decoded packet
/// re-encodes to exactly `in`. Returns the decode result.
template <typename Packet>
ParseError check_decode(std::span<const std::uint8_t> in, Packet& out) {
  out = sentinel<Packet>();
  const ParseError e = decode(in, kKey, out);
  if (e != ParseError::kOk) {
    FUZZ_CHECK(out == sentinel<Packet>());
    return e;
  }
  FUZZ_CHECK(out.session_id != 0);
  std::uint8_t again[kMaxPacketSize + 1];
  const std::size_t n = encode(out, kKey, again);
  FUZZ_CHECK(n == in.size());
  FUZZ_CHECK(std::memcmp(again, in.data(), n) == 0);
  return e;
}

/// One datagram through both decoders and fresh filters.
void check_datagram(std::span<const std::uint8_t> in) {
  CommandPacket c;
  StatePacket s;
  const ParseError ce = check_decode(in, c);
  const ParseError se = check_decode(in, s);
  FUZZ_CHECK(ce != ParseError::kOk || se != ParseError::kOk);  // the type byte decides
  FUZZ_CHECK(to_string(ce) != nullptr && to_string(se) != nullptr);
  FUZZ_CHECK(to_string(Verdict::kStale) != nullptr);
  if (ce == ParseError::kOk) FUZZ_CHECK((c.flags & ~kCommandKnownFlags) == 0);
  if (se == ParseError::kOk) FUZZ_CHECK((s.status & ~kStatusKnownBits) == 0);

  StatePacket out = sentinel<StatePacket>();
  StateFilter foreign(0xDEADBEEF, kKey);
  FUZZ_CHECK(foreign.accept(in, false, out) == Verdict::kForeignSource);
  StateFilter host(se == ParseError::kOk ? s.session_id : 1, kKey);
  const Verdict hv = host.accept(in, true, out);
  FUZZ_CHECK(hv == (se == ParseError::kOk ? Verdict::kAccept : rejected(se)));
  FUZZ_CHECK(hv == Verdict::kAccept ? out == s : out == sentinel<StatePacket>());
  if (hv != Verdict::kAccept) FUZZ_CHECK(host.last_error() == se);

  CommandFilter board(kKey);
  CommandPacket cout = sentinel<CommandPacket>();
  const Source opener{0x7F000001u, 1000};
  const Verdict bv = board.accept(in, opener, cout);
  const bool hello = ce == ParseError::kOk && c.type == PacketType::kHello;
  FUZZ_CHECK(bv == (ce == ParseError::kOk ? (hello ? Verdict::kHello : Verdict::kAccept) : rejected(ce)));
  if (hello) FUZZ_CHECK(c.board_nonce == 0 && c.flags == 0 && c.digital_out == 0);
  FUZZ_CHECK(board.has_session() == (bv == Verdict::kAccept));
  if (bv == Verdict::kAccept) {
    FUZZ_CHECK(cout == c && board.session_id() == c.session_id && board.peer() == opener);
    // The same datagram from anyone else is not obeyed while the session is held.
    CommandPacket other = sentinel<CommandPacket>();
    FUZZ_CHECK(board.accept(in, Source{0x7F000001u, 1001}, other) == Verdict::kForeignSource);
    FUZZ_CHECK(other == sentinel<CommandPacket>());
  }
}

// ---- script mode: reference models of the stream rules -----------------------------------------

constexpr std::uint32_t kSessions[4] = {0x0000A001, 0x0000B002, 0x0000C003, 0xFFFFFFFF};

/// Newest-only as the docs state it: accept if no baseline or (seq - last) as int32 is > 0.
struct SequenceModel {
  bool have_last = false;
  std::uint32_t last = 0;
  std::uint64_t gaps = 0;
  Verdict judge(std::uint32_t seq) {
    if (have_last) {
      const auto diff = static_cast<std::int32_t>(seq - last);
      if (diff == 0) return Verdict::kDuplicate;
      if (diff < 0) return Verdict::kStale;
      gaps += static_cast<std::uint32_t>(diff) - 1u;
    }
    have_last = true;
    last = seq;
    return Verdict::kAccept;
  }
};

struct BoardModel {
  bool has_session = false;
  std::uint32_t session = 0;
  int peer = -1;
  SequenceModel seq;
  Verdict judge(std::uint32_t s, std::uint32_t sequence, int source) {
    if (has_session && source != peer) return Verdict::kForeignSource;
    if (has_session && s != session) return Verdict::kForeignSession;
    if (!has_session && s != session) seq.have_last = false;  // adoption: fresh baseline
    const Verdict v = seq.judge(sequence);
    if (v == Verdict::kAccept) {
      has_session = true;
      session = s;
      peer = source;
    }
    return v;
  }
};

/// The re-arm rule as the docs state it.
struct ArmingModel {
  std::uint32_t session = 0;
  bool disabled_since_disarm = false;
  bool armed = false;
  bool estop = false;
  bool tripped = false;
  bool host_lost = false;
  std::uint64_t token = 0;  ///< the session's board nonce
};

/// Script record (8 bytes):
///   r[0] bit 0  the state packet comes from the board address; the command from endpoint A (else B)
///        bit 1  first, the host starts a new session: StateFilter::reset(kSessions[r[7] & 3])
///        bit 2  flip bit r[5] % 8 of byte r[3] % size of the encoded packet
///        bit 3  first, the board's watchdog fires (CommandFilter::release, OutputArming::on_watchdog)
///        bit 4  the packet is a command to the board (else a state packet to the host)
///        bit 5  first, the e-stop input changes to r[5] & 1
///        bits 6-7  session kSessions[r[0] >> 6] of the packet
///   r[1..2]  signed 16-bit step of the sequence number (starting at 0xFFFFFF00)
///   r[3]     bit flip: the byte (mod size); without a flip, bit 7 signs with another key
///   r[4]     command flags / state status, unknown bits included
///   r[5..7]  filler for the other fields; r[7] bit 7: the command carries the board's arm token
///            (else a stale one)
void run_script(const std::uint8_t* data, std::size_t size) {
  std::uint32_t host_session = kSessions[0];
  StateFilter host(host_session, kKey);
  SequenceModel host_model;
  CommandFilter board(kKey);
  LinkKey other_key = kKey;
  other_key.bytes[5] ^= 0x10;
  std::uint64_t tokens_drawn = 0;
  BoardModel board_model;
  OutputArming arming;
  ArmingModel arm;
  std::uint64_t host_calls = 0, board_calls = 0;
  std::uint32_t cursor = 0xFFFFFF00u;  // so that scripts cross the 2^32 wrap early

  for (std::size_t at = 0; at + 8 <= size; at += 8) {
    const std::uint8_t* r = data + at;
    const bool from_board = (r[0] & 0x01) != 0;
    const bool corrupt = (r[0] & 0x04) != 0;
    const bool to_board = (r[0] & 0x10) != 0;
    const std::uint32_t session = kSessions[r[0] >> 6];
    const bool wrong_key = !corrupt && (r[3] & 0x80) != 0;
    const int source = from_board ? 0 : 1;  // commands: endpoint A or B
    cursor += static_cast<std::uint32_t>(static_cast<std::int16_t>(r[1] | (r[2] << 8)));
    const std::uint8_t bits = r[4];

    if (r[0] & 0x02) {  // the host starts a new session
      FUZZ_CHECK(total(host.counters()) == host_calls);
      host_session = kSessions[r[7] & 3];
      host.reset(host_session);
      host_model = SequenceModel{};
      host_calls = 0;
    }
    if (r[0] & 0x08) {  // the board's watchdog fires
      board.release();
      board_model.has_session = false;
      arming.on_watchdog();
      if (arm.armed) arm.host_lost = true;
      arm.tripped = true;
      arm.armed = false;
      arm.disabled_since_disarm = false;
    }
    if (r[0] & 0x20) {  // the e-stop input changes
      const bool active = (r[5] & 1) != 0;
      arming.set_estop(active);
      arm.estop = active;
      if (active) {
        arm.armed = false;
        arm.disabled_since_disarm = false;
      }
    }

    std::uint8_t buf[kMaxPacketSize];
    std::size_t n = 0;
    bool unknown_bits = false;
    if (to_board) {
      CommandPacket c;
      c.session_id = session;
      c.sequence = cursor;
      c.host_time_ns = std::uint64_t{r[5]} << 40 | r[6];
      c.da[r[7] % kDaChannels] = static_cast<std::uint16_t>(r[6] << 8 | r[5]);
      c.digital_out = r[7];
      c.flags = bits;
      c.board_nonce = (r[7] & 0x80) ? arm.token : arm.token + 1;
      unknown_bits = (bits & ~kCommandKnownFlags) != 0;
      n = encode(c, wrong_key ? other_key : kKey, buf);
    } else {
      StatePacket s;
      s.session_id = session;
      s.sequence = cursor;
      s.ack_sequence = cursor ^ r[6];
      s.encoder[r[7] % kEncoderChannels] = static_cast<std::int8_t>(r[5]);
      s.status = bits;
      unknown_bits = (bits & ~kStatusKnownBits) != 0;
      n = encode(s, wrong_key ? other_key : kKey, buf);
    }
    FUZZ_CHECK(n != 0);
    if (corrupt) buf[(r[3] % n)] ^= static_cast<std::uint8_t>(1u << (r[5] % 8));
    // CRC-32C catches every single-bit flip before the MAC; a flip in the MAC or another key fails
    // the MAC, which is checked before the flag bits.
    const bool forged = wrong_key || (corrupt && r[3] % n >= n - kMacSize);
    const bool malformed = !forged && (corrupt || unknown_bits);
    const Verdict rejection = forged ? Verdict::kUnauthenticated : Verdict::kMalformed;
    const std::span<const std::uint8_t> datagram(buf, n);

    if (to_board) {
      Verdict expected = rejection;
      const bool had_session = board_model.has_session;
      if (!malformed && !forged) expected = board_model.judge(session, cursor, source);
      CommandPacket out = sentinel<CommandPacket>();
      const Verdict v = board.accept(datagram, Source{0x0A000001u, static_cast<std::uint16_t>(40000 + source)}, out);
      ++board_calls;
      FUZZ_CHECK(v == expected);
      FUZZ_CHECK(board.has_session() == board_model.has_session);
      FUZZ_CHECK(!board.has_session() || board.session_id() == board_model.session);
      FUZZ_CHECK(board.counters().gaps == board_model.seq.gaps);
      if (v == Verdict::kAccept) {
        FUZZ_CHECK(out.sequence == cursor && out.session_id == session);
        if (!had_session) {  // as the board does at each adoption: a fresh token
          arm.token = ++tokens_drawn;
          arming.set_token(arm.token);
        }
        arming.on_command(out);
        const bool enable = (out.flags & kCommandEnable) != 0;
        if (out.session_id != arm.session) {
          arm.session = out.session_id;
          arm.armed = false;
          arm.disabled_since_disarm = false;
        }
        if (!enable) {
          arm.armed = false;
          arm.tripped = false;
          arm.disabled_since_disarm = !arm.estop;
        } else if (!arm.armed && arm.disabled_since_disarm && !arm.estop && out.board_nonce == arm.token &&
                   (!arm.host_lost || (out.flags & kCommandOperatorArm) != 0)) {
          arm.armed = true;
          arm.host_lost = false;
        }
      } else {
        FUZZ_CHECK(out == sentinel<CommandPacket>());
      }
      FUZZ_CHECK(arming.outputs_enabled() == (arm.armed && !arm.estop));
      const std::uint8_t st = arming.status();
      FUZZ_CHECK(((st & kStatusOutputsSafe) != 0) == !arming.outputs_enabled());
      FUZZ_CHECK(((st & kStatusWatchdogTripped) != 0) == arm.tripped);
      FUZZ_CHECK(((st & kStatusEstop) != 0) == arm.estop);
      FUZZ_CHECK(((st & kStatusHostLost) != 0) == arm.host_lost);
      FUZZ_CHECK((st & ~kStatusKnownBits) == 0);
    } else {
      Verdict expected = Verdict::kForeignSource;
      if (from_board) {
        if (malformed || forged) {
          expected = rejection;
        } else if (session != host_session) {
          expected = Verdict::kForeignSession;
        } else {
          expected = host_model.judge(cursor);
        }
      }
      StatePacket out = sentinel<StatePacket>();
      const Verdict v = host.accept(datagram, from_board, out);
      ++host_calls;
      FUZZ_CHECK(v == expected);
      FUZZ_CHECK(host.counters().gaps == host_model.gaps);
      FUZZ_CHECK(v == Verdict::kAccept ? out.sequence == cursor : out == sentinel<StatePacket>());
    }
  }
  FUZZ_CHECK(total(host.counters()) == host_calls);
  FUZZ_CHECK(total(board.counters()) == board_calls);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in(data, size);
  check_datagram(in);

  // The same bytes with a correct CRC, then with a correct CRC and MAC (only for sizes a packet can
  // have, plus a little slack).
  if (size >= kTrailerSize && size <= kMaxPacketSize + 8) {
    std::uint8_t fixed[kMaxPacketSize + 8];
    std::memcpy(fixed, data, size);
    const std::size_t crc_at = size - kTrailerSize;
    const std::uint32_t crc = crc32c(fixed, crc_at);
    for (std::size_t i = 0; i < kCrcSize; ++i) fixed[crc_at + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    check_datagram(std::span<const std::uint8_t>(fixed, size));
    const auto mac = packet_mac(kKey, fixed, size - kMacSize);
    std::memcpy(fixed + size - kMacSize, mac.data(), kMacSize);
    check_datagram(std::span<const std::uint8_t>(fixed, size));
  }

  run_script(data, size);
  return 0;
}
