// The MFB wire protocol: layout, CRC, every rejection `decode` makes, and the stream rules of the
// host's StateFilter, the board's CommandFilter and its OutputArming (docs/mfb-protocol.md).
#include "peha/mfb/protocol.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace peha::mfb {
namespace {

using Bytes = std::vector<std::uint8_t>;

/// The key of the golden packets: bytes 0x00..0x1F.
LinkKey test_key() {
  LinkKey k;
  for (std::size_t i = 0; i < kKeySize; ++i) k.bytes[i] = static_cast<std::uint8_t>(i);
  return k;
}
const LinkKey kKey = test_key();
/// The endpoint the board's tests open their sessions from.
constexpr Source kHost{0x7F000001u, 40000};

// ---- helpers ------------------------------------------------------------------------------------

Bytes encoded(const CommandPacket& c) {
  Bytes b(kCommandPacketSize);
  EXPECT_EQ(encode(c, kKey, b), kCommandPacketSize);
  return b;
}

Bytes encoded(const StatePacket& s) {
  Bytes b(kStatePacketSize);
  EXPECT_EQ(encode(s, kKey, b), kStatePacketSize);
  return b;
}

/// Recomputes the CRC only (what a forger without the key can do).
void fix_crc(Bytes& b) {
  const std::size_t at = b.size() - kTrailerSize;
  const std::uint32_t crc = crc32c(b.data(), at);
  for (std::size_t i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(crc >> (8 * i));
}

/// Recomputes CRC and MAC under `key`, so that a test can reach the checks that come after them.
void fix_trailer(Bytes& b, const LinkKey& key = kKey) {
  fix_crc(b);
  const auto mac = packet_mac(key, b.data(), b.size() - kMacSize);
  std::copy(mac.begin(), mac.end(), b.end() - static_cast<std::ptrdiff_t>(kMacSize));
}

CommandPacket random_command(std::mt19937_64& rng) {
  CommandPacket c;
  c.session_id = static_cast<std::uint32_t>(rng()) | 1u;  // nonzero
  c.sequence = static_cast<std::uint32_t>(rng());
  c.host_time_ns = rng();
  for (auto& d : c.da) d = static_cast<std::uint16_t>(rng());
  c.digital_out = static_cast<std::uint8_t>(rng());
  c.flags = static_cast<std::uint8_t>(rng() & kCommandKnownFlags);
  c.board_nonce = rng();
  return c;
}

StatePacket random_state(std::mt19937_64& rng) {
  StatePacket s;
  s.session_id = static_cast<std::uint32_t>(rng()) | 1u;
  s.sequence = static_cast<std::uint32_t>(rng());
  s.ack_sequence = static_cast<std::uint32_t>(rng());
  s.echo_host_time_ns = rng();
  s.board_time_ns = rng();
  for (auto& a : s.ad) a = static_cast<std::uint16_t>(rng());
  for (auto& e : s.encoder) e = static_cast<std::int32_t>(static_cast<std::uint32_t>(rng()));
  s.digital_in = static_cast<std::uint8_t>(rng());
  s.status = static_cast<std::uint8_t>(rng() & kStatusKnownBits);
  s.board_nonce = rng();
  s.boot_id = static_cast<std::uint32_t>(rng());
  s.limit_vented = static_cast<std::uint16_t>(rng());
  s.limit_motor_off = static_cast<std::uint8_t>(rng());
  return s;
}

CommandPacket command(std::uint32_t session, std::uint32_t sequence, std::uint8_t flags = 0) {
  CommandPacket c;
  c.session_id = session;
  c.sequence = sequence;
  c.host_time_ns = 1000u * sequence;
  c.flags = flags;
  return c;
}

StatePacket state(std::uint32_t session, std::uint32_t sequence) {
  StatePacket s;
  s.session_id = session;
  s.sequence = sequence;
  s.board_time_ns = 7u * sequence;
  return s;
}

/// Bit-at-a-time CRC-32C straight from the definition, to check the table-driven one.
std::uint32_t crc32c_bitwise(const std::uint8_t* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1u) ? (crc >> 1) ^ 0x82F63B78u : crc >> 1;
  }
  return ~crc;
}

// The packets of the golden-byte tests. Every multi-byte field has distinct bytes, so a wrong
// offset, a swapped byte order or a field written twice changes the bytes.
CommandPacket golden_command() {
  CommandPacket c;
  c.session_id = 0x11223344;
  c.sequence = 0x55667788;
  c.host_time_ns = 0x0102030405060708;
  for (std::size_t i = 0; i < c.da.size(); ++i) c.da[i] = static_cast<std::uint16_t>(0xA0B0 + 0x0101 * i);
  c.digital_out = 0xC3;
  c.flags = kCommandEnable;
  c.board_nonce = 0xF1F2F3F4F5F6F7F8;
  return c;
}

StatePacket golden_state() {
  StatePacket s;
  s.session_id = 0x11223344;
  s.sequence = 0x0A0B0C0D;
  s.echo_host_time_ns = 0x0102030405060708;
  s.board_time_ns = 0x1112131415161718;
  s.ack_sequence = 0x55667788;
  for (std::size_t i = 0; i < s.ad.size(); ++i) s.ad[i] = static_cast<std::uint16_t>(0xD0E0 + 0x0101 * i);
  s.encoder = {-1, 1, std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::min(),
               -123456789, 0x01020304, 0, -2};
  s.digital_in = 0x5A;
  s.status = kStatusOutputsSafe | kStatusNoSession;
  s.board_nonce = 0x2122232425262728;
  s.boot_id = 0x31323334;
  s.limit_vented = 0x8421;
  s.limit_motor_off = 0x5C;
  return s;
}

// Written by hand from the byte table in docs/mfb-protocol.md, not produced by `encode`. The CRC
// bytes come from an independent bit-at-a-time CRC-32C (Python) over the preceding bytes, the MAC
// from Python's hashlib.blake2b(digest_size=16, key=bytes(range(32))) over everything before it.
const Bytes kGoldenCommand = {
    0x4D, 0x46, 0x42, 0x31,                          // magic 'MFB1'
    0x05,                                            // version
    0x01,                                            // type: command
    0x22, 0x00,                                      // payload length 34
    0x44, 0x33, 0x22, 0x11,                          // session 0x11223344
    0x88, 0x77, 0x66, 0x55,                          // sequence 0x55667788
    0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,  // host_time_ns
    0xB0, 0xA0, 0xB1, 0xA1, 0xB2, 0xA2, 0xB3, 0xA3,  // da[0..3]
    0xB4, 0xA4, 0xB5, 0xA5, 0xB6, 0xA6, 0xB7, 0xA7,  // da[4..7]
    0xC3,                                            // digital_out
    0x01,                                            // flags: enable
    0xF8, 0xF7, 0xF6, 0xF5, 0xF4, 0xF3, 0xF2, 0xF1,  // board_nonce 0xF1F2F3F4F5F6F7F8
    0x96, 0x87, 0xB6, 0xFE,                          // CRC-32C of bytes 0..49
    0x64, 0xEE, 0xD9, 0xBD, 0xED, 0x42, 0x91, 0x36,  // MAC (keyed BLAKE2b-128) of bytes 0..53
    0xB2, 0x09, 0x17, 0x1D, 0x01, 0xB4, 0x17, 0x6D,
};

const Bytes kGoldenState = {
    0x4D, 0x46, 0x42, 0x31,                          // magic 'MFB1'
    0x05,                                            // version
    0x02,                                            // type: state
    0x65, 0x00,                                      // payload length 101
    0x44, 0x33, 0x22, 0x11,                          // session 0x11223344
    0x0D, 0x0C, 0x0B, 0x0A,                          // sequence 0x0A0B0C0D
    0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,  // echo_host_time_ns
    0x18, 0x17, 0x16, 0x15, 0x14, 0x13, 0x12, 0x11,  // board_time_ns
    0x88, 0x77, 0x66, 0x55,                          // ack_sequence
    0xE0, 0xD0, 0xE1, 0xD1, 0xE2, 0xD2, 0xE3, 0xD3,  // ad[0..3]
    0xE4, 0xD4, 0xE5, 0xD5, 0xE6, 0xD6, 0xE7, 0xD7,  // ad[4..7]
    0xE8, 0xD8, 0xE9, 0xD9, 0xEA, 0xDA, 0xEB, 0xDB,  // ad[8..11]
    0xEC, 0xDC, 0xED, 0xDD, 0xEE, 0xDE, 0xEF, 0xDF,  // ad[12..15]
    0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0x00, 0x00, 0x00,  // encoder[0] = -1, [1] = 1
    0xFF, 0xFF, 0xFF, 0x7F, 0x00, 0x00, 0x00, 0x80,  // encoder[2] = INT32_MAX, [3] = INT32_MIN
    0xEB, 0x32, 0xA4, 0xF8, 0x04, 0x03, 0x02, 0x01,  // encoder[4] = -123456789, [5] = 0x01020304
    0x00, 0x00, 0x00, 0x00, 0xFE, 0xFF, 0xFF, 0xFF,  // encoder[6] = 0, [7] = -2
    0x5A,                                            // digital_in
    0x0A,                                            // status: outputs safe | no session
    0x28, 0x27, 0x26, 0x25, 0x24, 0x23, 0x22, 0x21,  // board_nonce 0x2122232425262728
    0x34, 0x33, 0x32, 0x31,                          // boot_id 0x31323334
    0x21, 0x84,                                      // limit_vented 0x8421
    0x5C,                                            // limit_motor_off 0x5C
    0xE7, 0x46, 0xFF, 0x50,                          // CRC-32C of bytes 0..116
    0x7A, 0xF9, 0xFF, 0x78, 0x91, 0xBA, 0x3A, 0xE7,  // MAC (keyed BLAKE2b-128) of bytes 0..120
    0xE8, 0x8F, 0x42, 0x88, 0x9C, 0x3F, 0xDB, 0xB7,
};

// ---- CRC and layout -----------------------------------------------------------------------------

TEST(MfbProtocol, Crc32cHasTheCastagnoliCheckValue) {
  const char* check = "123456789";
  EXPECT_EQ(crc32c(reinterpret_cast<const std::uint8_t*>(check), 9), 0xE3069283u);
  EXPECT_EQ(crc32c(nullptr, 0), 0u);  // init and final XOR cancel on empty input
}

TEST(MfbProtocol, Crc32cTableAgreesWithBitwiseDefinition) {
  std::mt19937_64 rng(1);
  for (std::size_t size = 0; size < 300; ++size) {
    Bytes b(size);
    for (auto& x : b) x = static_cast<std::uint8_t>(rng());
    ASSERT_EQ(crc32c(b.data(), b.size()), crc32c_bitwise(b.data(), b.size())) << "size " << size;
  }
}

TEST(MfbProtocol, WireSizesMatchTheLayoutTable) {
  // 16 header + 8 time + 8x2 DA + 1 + 1 + 8 nonce + 4 CRC + 16 MAC;
  // 16 header + 8 + 8 + 4 + 16x2 AD + 8x4 enc + 1 + 1 + 8 nonce + 4 boot id + 2 + 1 limits + 4 CRC + 16 MAC.
  EXPECT_EQ(kCommandPacketSize, 70u);
  EXPECT_EQ(kStatePacketSize, 137u);
  EXPECT_EQ(kMaxPacketSize, 137u);
  EXPECT_EQ(kCommandBoardNonceOffset + 8, kHeaderSize + kCommandPayloadSize);
  EXPECT_EQ(kStateBoardNonceOffset + 8, kStateBootIdOffset);
  EXPECT_EQ(kStateBootIdOffset + 4, kStateLimitVentedOffset);
  EXPECT_EQ(kStateLimitVentedOffset + 2, kStateLimitMotorOffOffset);
  EXPECT_EQ(kStateLimitMotorOffOffset + 1, kHeaderSize + kStatePayloadSize);
  EXPECT_EQ(kGoldenCommand.size(), kCommandPacketSize);
  EXPECT_EQ(kGoldenState.size(), kStatePacketSize);
}

TEST(MfbProtocol, EncodesCommandToGoldenBytes) {
  EXPECT_EQ(encoded(golden_command()), kGoldenCommand);
  CommandPacket c;
  ASSERT_EQ(decode(kGoldenCommand, kKey, c), ParseError::kOk);
  EXPECT_EQ(c, golden_command());
}

TEST(MfbProtocol, EncodesStateToGoldenBytes) {
  EXPECT_EQ(encoded(golden_state()), kGoldenState);
  StatePacket s;
  ASSERT_EQ(decode(kGoldenState, kKey, s), ParseError::kOk);
  EXPECT_EQ(s, golden_state());
}

TEST(MfbProtocol, RandomPacketsRoundTripBitExact) {
  std::mt19937_64 rng(2);
  for (int i = 0; i < 20000; ++i) {
    const CommandPacket c = random_command(rng);
    const Bytes cb = encoded(c);
    CommandPacket c2;
    ASSERT_EQ(decode(cb, kKey, c2), ParseError::kOk);
    ASSERT_EQ(c2, c);
    ASSERT_EQ(encoded(c2), cb);

    const StatePacket s = random_state(rng);
    const Bytes sb = encoded(s);
    StatePacket s2;
    ASSERT_EQ(decode(sb, kKey, s2), ParseError::kOk);
    ASSERT_EQ(s2, s);
    ASSERT_EQ(encoded(s2), sb);
  }
}

TEST(MfbProtocol, EncodeWritesNothingIntoTooSmallBuffer) {
  Bytes b(kCommandPacketSize - 1, 0xEE);
  EXPECT_EQ(encode(golden_command(), kKey, b), 0u);
  EXPECT_EQ(b, Bytes(kCommandPacketSize - 1, 0xEE));
  Bytes s(kStatePacketSize - 1, 0xEE);
  EXPECT_EQ(encode(golden_state(), kKey, s), 0u);
  EXPECT_EQ(s, Bytes(kStatePacketSize - 1, 0xEE));
  // A larger buffer is fine: only the packet's bytes are written.
  Bytes big(kMaxPacketSize + 10, 0xEE);
  EXPECT_EQ(encode(golden_command(), kKey, big), kCommandPacketSize);
  EXPECT_EQ(big[kCommandPacketSize], 0xEE);
}

// ---- rejections ---------------------------------------------------------------------------------

TEST(MfbProtocol, RejectsEveryTruncation) {
  for (std::size_t n = 0; n < kCommandPacketSize; ++n) {
    CommandPacket c;
    ASSERT_EQ(decode(std::span(kGoldenCommand).first(n), kKey, c), ParseError::kTooShort) << n << " bytes";
  }
  for (std::size_t n = 0; n < kStatePacketSize; ++n) {
    StatePacket s;
    ASSERT_EQ(decode(std::span(kGoldenState).first(n), kKey, s), ParseError::kTooShort) << n << " bytes";
  }
}

TEST(MfbProtocol, RejectsPacketOneByteTooLong) {
  Bytes c = kGoldenCommand;
  c.push_back(0);
  CommandPacket cp;
  EXPECT_EQ(decode(c, kKey, cp), ParseError::kTooLong);
  Bytes s = kGoldenState;
  s.push_back(0);
  StatePacket sp;
  EXPECT_EQ(decode(s, kKey, sp), ParseError::kTooLong);
}

/// What a single flipped bit at `byte` of a `size`-byte packet must be rejected as: the header
/// checks catch their own fields first, the CRC everything up to itself (CRC-32C detects every
/// single-bit error), the MAC a flip in the MAC.
ParseError expected_for_flip_at(std::size_t byte, std::size_t size) {
  if (byte < kVersionOffset) return ParseError::kBadMagic;
  if (byte == kVersionOffset) return ParseError::kBadVersion;
  if (byte == kTypeOffset) return ParseError::kWrongType;
  if (byte < kSessionOffset) return ParseError::kBadLength;
  return byte < size - kMacSize ? ParseError::kBadCrc : ParseError::kBadMac;
}

TEST(MfbProtocol, RejectsPacketWithOneFlippedBit) {
  for (std::size_t bit = 0; bit < 8 * kCommandPacketSize; ++bit) {
    Bytes b = kGoldenCommand;
    b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    CommandPacket c;
    // Type 1 with bit 1 flipped is 3, a hello: a command's layout, so its CRC is what fails.
    const bool to_hello = bit / 8 == kTypeOffset && b[kTypeOffset] == static_cast<std::uint8_t>(PacketType::kHello);
    ASSERT_EQ(decode(b, kKey, c), to_hello ? ParseError::kBadCrc : expected_for_flip_at(bit / 8, kCommandPacketSize))
        << "command bit " << bit;
  }
  for (std::size_t bit = 0; bit < 8 * kStatePacketSize; ++bit) {
    Bytes b = kGoldenState;
    b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    StatePacket s;
    ASSERT_EQ(decode(b, kKey, s), expected_for_flip_at(bit / 8, kStatePacketSize)) << "state bit " << bit;
  }
}

// CRC-32C's Hamming distance at these lengths is >= 6, so every 2-bit error is caught as well.
TEST(MfbProtocol, RejectsPacketWithTwoFlippedBits) {
  for (std::size_t i = 0; i < 8 * kStatePacketSize; ++i) {
    for (std::size_t j = i + 1; j < 8 * kStatePacketSize; ++j) {
      Bytes b = kGoldenState;
      b[i / 8] ^= static_cast<std::uint8_t>(1u << (i % 8));
      b[j / 8] ^= static_cast<std::uint8_t>(1u << (j % 8));
      StatePacket s;
      ASSERT_NE(decode(b, kKey, s), ParseError::kOk) << "bits " << i << ", " << j;
    }
  }
}

TEST(MfbProtocol, RejectsWrongMagic) {
  Bytes b = kGoldenCommand;
  std::memcpy(b.data(), "MFB2", 4);
  fix_trailer(b);
  CommandPacket c;
  EXPECT_EQ(decode(b, kKey, c), ParseError::kBadMagic);
  b = kGoldenCommand;
  std::memcpy(b.data(), "1BFM", 4);  // big-endian magic
  EXPECT_EQ(decode(b, kKey, c), ParseError::kBadMagic);
}

TEST(MfbProtocol, RejectsOtherVersionsEvenWithValidCrc) {
  for (int version : {0, 1, 2, 3, 4, 6, 255}) {
    Bytes b = kGoldenState;
    b[kVersionOffset] = static_cast<std::uint8_t>(version);
    fix_trailer(b);
    StatePacket s;
    EXPECT_EQ(decode(b, kKey, s), ParseError::kBadVersion) << version;
    b.resize(30);  // another version may have another size: the version is still what is reported
    EXPECT_EQ(decode(b, kKey, s), ParseError::kBadVersion) << version;
  }
}

TEST(MfbProtocol, RejectsPacketOfTheOtherType) {
  CommandPacket c;
  StatePacket s;
  EXPECT_EQ(decode(kGoldenState, kKey, c), ParseError::kWrongType);
  EXPECT_EQ(decode(kGoldenCommand, kKey, s), ParseError::kWrongType);
  for (int type : {0, 2, 4, 255}) {
    Bytes b = kGoldenCommand;
    b[kTypeOffset] = static_cast<std::uint8_t>(type);
    fix_trailer(b);
    EXPECT_EQ(decode(b, kKey, c), ParseError::kWrongType) << type;
  }
  Bytes hello = kGoldenState;  // a hello is never a state
  hello[kTypeOffset] = static_cast<std::uint8_t>(PacketType::kHello);
  fix_trailer(hello);
  EXPECT_EQ(decode(hello, kKey, s), ParseError::kWrongType);
}

// A hello has the command's layout and drives nothing: with any output, flag or nonce it is refused.
TEST(MfbProtocol, AHelloCarriesNoOutputsFlagsOrNonce) {
  CommandPacket h;
  h.type = PacketType::kHello;
  h.session_id = 0x11223344;
  h.sequence = 9;
  h.host_time_ns = 123;
  CommandPacket out;
  ASSERT_EQ(decode(encoded(h), kKey, out), ParseError::kOk);
  EXPECT_EQ(out, h);
  for (int field = 0; field < 4; ++field) {
    CommandPacket bad = h;
    if (field == 0) bad.da[3] = 1;
    if (field == 1) bad.digital_out = 1;
    if (field == 2) bad.flags = kCommandEnable;
    if (field == 3) bad.board_nonce = 1;
    EXPECT_EQ(decode(encoded(bad), kKey, out), ParseError::kBadFlags) << field;
  }
}

TEST(MfbProtocol, RejectsLengthFieldThatDisagreesWithType) {
  for (unsigned length : {0u, 25u, 27u, 86u, 0xFFFFu}) {
    Bytes b = kGoldenCommand;
    b[kPayloadLengthOffset] = static_cast<std::uint8_t>(length);
    b[kPayloadLengthOffset + 1] = static_cast<std::uint8_t>(length >> 8);
    fix_trailer(b);
    CommandPacket c;
    EXPECT_EQ(decode(b, kKey, c), ParseError::kBadLength) << length;
  }
}

TEST(MfbProtocol, RejectsUnknownFlagBits) {
  for (int bit = 2; bit < 8; ++bit) {
    CommandPacket c = golden_command();
    c.flags = static_cast<std::uint8_t>(kCommandEnable | (1u << bit));
    CommandPacket out;
    EXPECT_EQ(decode(encoded(c), kKey, out), ParseError::kBadFlags) << "flag bit " << bit;
  }
  for (int bit = 5; bit < 8; ++bit) {
    StatePacket s = golden_state();
    s.status = static_cast<std::uint8_t>(1u << bit);
    StatePacket out;
    EXPECT_EQ(decode(encoded(s), kKey, out), ParseError::kBadFlags) << "status bit " << bit;
  }
}

TEST(MfbProtocol, RejectsZeroSession) {
  CommandPacket c = golden_command();
  c.session_id = 0;
  CommandPacket cout;
  EXPECT_EQ(decode(encoded(c), kKey, cout), ParseError::kZeroSession);
  StatePacket s = golden_state();
  s.session_id = 0;
  StatePacket sout;
  EXPECT_EQ(decode(encoded(s), kKey, sout), ParseError::kZeroSession);
}

TEST(MfbProtocol, LeavesOutputUntouchedOnRejection) {
  Bytes b = kGoldenCommand;
  b[20] ^= 0x10;
  CommandPacket c = command(99, 98);
  EXPECT_EQ(decode(b, kKey, c), ParseError::kBadCrc);
  EXPECT_EQ(c, command(99, 98));
  StatePacket s = state(99, 98);
  EXPECT_EQ(decode(std::span(kGoldenState).first(50), kKey, s), ParseError::kTooShort);
  EXPECT_EQ(s, state(99, 98));
}

TEST(MfbProtocol, NamesEveryErrorAndVerdictDistinctly) {
  std::set<std::string> names;
  for (int e = 0; e <= static_cast<int>(ParseError::kZeroSession); ++e) {
    names.insert(to_string(static_cast<ParseError>(e)));
  }
  EXPECT_EQ(names.size(), 11u);
  names.clear();
  for (int v = 0; v <= static_cast<int>(Verdict::kUnauthenticated); ++v) {
    names.insert(to_string(static_cast<Verdict>(v)));
  }
  EXPECT_EQ(names.size(), 7u);
}

TEST(MfbProtocol, OrdersSequenceNumbersAcrossTheWrap) {
  EXPECT_TRUE(sequence_newer(1, 0));
  EXPECT_FALSE(sequence_newer(0, 1));
  EXPECT_FALSE(sequence_newer(5, 5));
  EXPECT_TRUE(sequence_newer(0, 0xFFFFFFFF));
  EXPECT_TRUE(sequence_newer(3, 0xFFFFFFFE));
  EXPECT_FALSE(sequence_newer(0xFFFFFFFF, 0));
  EXPECT_TRUE(sequence_newer(0x7FFFFFFF, 0));   // 2^31 - 1 ahead: newer
  EXPECT_FALSE(sequence_newer(0x80000000, 0));  // 2^31 ahead: ambiguous, treated as older
}

// ---- StateFilter (host) -------------------------------------------------------------------------

constexpr std::uint32_t kSession = 0xC0FFEE01;

TEST(StateFilter, AcceptsInOrderPacketsOfItsSession) {
  StateFilter f(kSession, kKey);
  for (std::uint32_t seq = 100; seq < 110; ++seq) {
    StatePacket out;
    ASSERT_EQ(f.accept(encoded(state(kSession, seq)), true, out), Verdict::kAccept);
    EXPECT_EQ(out, state(kSession, seq));
  }
  EXPECT_EQ(f.counters().accepted, 10u);
  EXPECT_EQ(f.counters().gaps, 0u);
}

TEST(StateFilter, DropsValidPacketFromForeignSource) {
  StateFilter f(kSession, kKey);
  StatePacket out = state(1, 1);
  EXPECT_EQ(f.accept(encoded(state(kSession, 5)), false, out), Verdict::kForeignSource);
  EXPECT_EQ(out, state(1, 1));
  EXPECT_EQ(f.counters().foreign_source, 1u);
  // The dropped packet did not become the baseline: an older one from the board is still accepted.
  EXPECT_EQ(f.accept(encoded(state(kSession, 4)), true, out), Verdict::kAccept);
}

TEST(StateFilter, DropsPacketOfAnotherSession) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  EXPECT_EQ(f.accept(encoded(state(kSession + 1, 5)), true, out), Verdict::kForeignSession);
  EXPECT_EQ(f.counters().foreign_session, 1u);
  EXPECT_EQ(f.counters().accepted, 0u);
}

TEST(StateFilter, DropsDuplicate) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  ASSERT_EQ(f.accept(encoded(state(kSession, 5)), true, out), Verdict::kAccept);
  EXPECT_EQ(f.accept(encoded(state(kSession, 5)), true, out), Verdict::kDuplicate);
  EXPECT_EQ(f.counters().duplicate, 1u);
}

TEST(StateFilter, DropsReorderedOlderPacketAndKeepsItsGapCounted) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  ASSERT_EQ(f.accept(encoded(state(kSession, 10)), true, out), Verdict::kAccept);
  ASSERT_EQ(f.accept(encoded(state(kSession, 12)), true, out), Verdict::kAccept);  // 11 overtaken
  EXPECT_EQ(f.accept(encoded(state(kSession, 11)), true, out), Verdict::kStale);
  EXPECT_EQ(out.sequence, 12u);
  EXPECT_EQ(f.counters().stale, 1u);
  EXPECT_EQ(f.counters().gaps, 1u);
}

// A board that restarts under a run (power glitch, watchdog reset of its firmware) comes back with
// a new boot id, its sequence counter from 1, and adopts the host's session again: its packets must
// reach the host - as a restart, counted - instead of being dropped as stale until the counter
// catches up (2^31 packets, 25 days), which would look like a dead board that no recovery revives.
TEST(StateFilter, AcceptsANewBootOfTheBoardAsARestartAndNeverGoesBack) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  StatePacket before = state(kSession, 5000);
  before.boot_id = 0xB0070001;
  ASSERT_EQ(f.accept(encoded(before), true, out), Verdict::kAccept);
  EXPECT_EQ(f.counters().reboots, 0u);
  EXPECT_EQ(f.boot_id(), 0xB0070001u);
  StatePacket after = state(kSession, 1);  // the restarted board's first packet
  after.boot_id = 0xB0070002;
  ASSERT_EQ(f.accept(encoded(after), true, out), Verdict::kAccept);
  EXPECT_EQ(out, after);
  EXPECT_EQ(f.counters().reboots, 1u);
  EXPECT_EQ(f.boot_id(), 0xB0070002u);
  EXPECT_EQ(f.counters().gaps, 0u);  // a new counter, not 2^32 - 4999 skipped numbers
  after.sequence = 2;
  EXPECT_EQ(f.accept(encoded(after), true, out), Verdict::kAccept);
  EXPECT_EQ(f.accept(encoded(after), true, out), Verdict::kDuplicate);  // the newest-only rule holds in the new boot
  // A late (or replayed) packet of the boot it replaced cannot switch back, however new its sequence.
  before.sequence = 5001;
  EXPECT_EQ(f.accept(encoded(before), true, out), Verdict::kStale);
  EXPECT_EQ(f.counters().reboots, 1u);
  EXPECT_EQ(f.boot_id(), 0xB0070002u);
  // The first packet of a session is a baseline, not a restart.
  f.reset(kSession);
  ASSERT_EQ(f.accept(encoded(before), true, out), Verdict::kAccept);
  EXPECT_EQ(f.counters().reboots, 0u);
}

TEST(StateFilter, AcceptsAcrossSequenceWrapAround) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  for (std::uint32_t seq : {0xFFFFFFFEu, 0xFFFFFFFFu, 0u, 1u}) {
    ASSERT_EQ(f.accept(encoded(state(kSession, seq)), true, out), Verdict::kAccept) << seq;
  }
  EXPECT_EQ(f.accept(encoded(state(kSession, 0xFFFFFFFFu)), true, out), Verdict::kStale);
  EXPECT_EQ(f.counters().gaps, 0u);
}

TEST(StateFilter, CountsSkippedSequencesAsGapsAcrossTheWrap) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  ASSERT_EQ(f.accept(encoded(state(kSession, 0xFFFFFFFDu)), true, out), Verdict::kAccept);
  ASSERT_EQ(f.accept(encoded(state(kSession, 2u)), true, out), Verdict::kAccept);  // skips FE, FF, 0, 1
  EXPECT_EQ(f.counters().gaps, 4u);
  ASSERT_EQ(f.accept(encoded(state(kSession, 12u)), true, out), Verdict::kAccept);  // skips 3..11
  EXPECT_EQ(f.counters().gaps, 13u);
}

TEST(StateFilter, CountsMalformedAndRemembersWhy) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  Bytes b = encoded(state(kSession, 1));
  b[50] ^= 0x01;
  EXPECT_EQ(f.accept(b, true, out), Verdict::kMalformed);
  EXPECT_EQ(f.last_error(), ParseError::kBadCrc);
  EXPECT_EQ(f.accept(encoded(command(kSession, 1)), true, out), Verdict::kMalformed);
  EXPECT_EQ(f.last_error(), ParseError::kWrongType);
  EXPECT_EQ(f.counters().malformed, 2u);
}

TEST(StateFilter, CountsEveryDatagramExactlyOnce) {
  StateFilter f(kSession, kKey);
  std::mt19937_64 rng(3);
  StatePacket out;
  const int n = 5000;
  for (int i = 0; i < n; ++i) {
    const std::uint32_t session = rng() % 4 == 0 ? kSession + 1 : kSession;
    Bytes b = encoded(state(session, static_cast<std::uint32_t>(rng() % 64)));
    if (rng() % 8 == 0) b[rng() % b.size()] ^= 0x40;
    f.accept(b, rng() % 16 != 0, out);
  }
  const ReceiveCounters& c = f.counters();
  EXPECT_EQ(c.accepted + c.foreign_source + c.foreign_session + c.duplicate + c.stale + c.malformed + c.unauthenticated,
            static_cast<std::uint64_t>(n));
}

TEST(StateFilter, ResetStartsNewSessionFromScratch) {
  StateFilter f(kSession, kKey);
  StatePacket out;
  ASSERT_EQ(f.accept(encoded(state(kSession, 100)), true, out), Verdict::kAccept);
  f.reset(kSession + 1);
  EXPECT_EQ(f.counters().accepted, 0u);
  EXPECT_EQ(f.accept(encoded(state(kSession, 101)), true, out), Verdict::kForeignSession);
  EXPECT_EQ(f.accept(encoded(state(kSession + 1, 50)), true, out), Verdict::kAccept);  // no baseline
}

// ---- CommandFilter (board) ----------------------------------------------------------------------

TEST(CommandFilter, AdoptsSessionOfFirstValidCommand) {
  CommandFilter f(kKey);
  EXPECT_FALSE(f.has_session());
  CommandPacket out;
  Bytes corrupt = encoded(command(7, 1));
  corrupt[30] ^= 0x80;
  EXPECT_EQ(f.accept(corrupt, kHost, out), Verdict::kMalformed);  // a corrupt command adopts nothing
  EXPECT_FALSE(f.has_session());
  ASSERT_EQ(f.accept(encoded(command(7, 1000)), kHost, out), Verdict::kAccept);
  EXPECT_TRUE(f.has_session());
  EXPECT_EQ(f.session_id(), 7u);
  EXPECT_EQ(out, command(7, 1000));
}

TEST(CommandFilter, IgnoresOtherHostWhileHoldingSession) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 1)), kHost, out), Verdict::kAccept);
  EXPECT_EQ(f.accept(encoded(command(8, 1)), kHost, out), Verdict::kForeignSession);
  EXPECT_EQ(f.accept(encoded(command(8, 2)), kHost, out), Verdict::kForeignSession);
  EXPECT_EQ(out, command(7, 1));
  EXPECT_EQ(f.session_id(), 7u);
  EXPECT_EQ(f.counters().foreign_session, 2u);
}

TEST(CommandFilter, AppliesNewestOnlyWithinSession) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 0xFFFFFFFF)), kHost, out), Verdict::kAccept);
  EXPECT_EQ(f.accept(encoded(command(7, 0xFFFFFFFF)), kHost, out), Verdict::kDuplicate);
  EXPECT_EQ(f.accept(encoded(command(7, 2)), kHost, out), Verdict::kAccept);  // across the wrap, skips 0, 1
  EXPECT_EQ(f.accept(encoded(command(7, 1)), kHost, out), Verdict::kStale);
  EXPECT_EQ(f.counters().gaps, 2u);
  EXPECT_EQ(f.counters().foreign_source, 0u);
}

TEST(CommandFilter, AdoptsNewHostAfterWatchdogRelease) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 500)), kHost, out), Verdict::kAccept);
  f.release();
  EXPECT_FALSE(f.has_session());
  EXPECT_EQ(f.session_id(), 7u);  // still reported in the state packets
  ASSERT_EQ(f.accept(encoded(command(8, 3)), kHost, out), Verdict::kAccept);  // new baseline: 3 < 500 is fine
  EXPECT_TRUE(f.has_session());
  EXPECT_EQ(f.session_id(), 8u);
  EXPECT_EQ(f.accept(encoded(command(7, 501)), kHost, out), Verdict::kForeignSession);
  EXPECT_EQ(f.counters().gaps, 0u);
}

TEST(CommandFilter, LateCommandCannotReviveReleasedSession) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 500)), kHost, out), Verdict::kAccept);
  f.release();
  EXPECT_EQ(f.accept(encoded(command(7, 499)), kHost, out), Verdict::kStale);  // delayed in a switch queue
  EXPECT_FALSE(f.has_session());
  ASSERT_EQ(f.accept(encoded(command(7, 520)), kHost, out), Verdict::kAccept);  // the host resumes
  EXPECT_TRUE(f.has_session());
  EXPECT_EQ(f.counters().gaps, 19u);
}

// Issue 11: a process on the link copies the host's session id and sends commands with a higher
// sequence from another port. Even with the key (an insider), it is neither obeyed nor answered
// while the session is held, and the real host's next command is still accepted (before: the
// stranger's commands were applied and the host's dropped as stale).
TEST(CommandFilter, ObeysOnlyTheEndpointThatOpenedTheSession) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 10)), kHost, out), Verdict::kAccept);
  const Source stranger{kHost.address, static_cast<std::uint16_t>(kHost.port + 1)};
  for (std::uint32_t seq = 1000; seq < 1010; ++seq) {
    EXPECT_EQ(f.accept(encoded(command(7, seq, kCommandEnable)), stranger, out), Verdict::kForeignSource);
  }
  EXPECT_EQ(f.accept(encoded(command(7, 1)), Source{0x0A000002u, kHost.port}, out), Verdict::kForeignSource);  // other address
  EXPECT_EQ(out, command(7, 10));
  EXPECT_EQ(f.counters().foreign_source, 11u);
  EXPECT_EQ(f.accept(encoded(command(7, 11)), kHost, out), Verdict::kAccept);
  EXPECT_EQ(f.peer(), kHost);
}

// Without the key, a copied command with a higher sequence (CRC recomputed) is rejected as
// unauthenticated and counted; so is every packet under another key.
TEST(CommandFilter, RejectsAndCountsACommandWithABadMac) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 10)), kHost, out), Verdict::kAccept);
  Bytes forged = encoded(command(7, 10));
  forged[kSequenceOffset] = 0xFF;  // sequence 0x000000FF
  forged[kCommandFlagsOffset] = kCommandEnable;
  fix_crc(forged);
  EXPECT_EQ(f.accept(forged, kHost, out), Verdict::kUnauthenticated);
  EXPECT_EQ(f.last_error(), ParseError::kBadMac);
  LinkKey other = kKey;
  other.bytes[0] ^= 1;
  Bytes wrong_key = encoded(command(7, 20));
  fix_trailer(wrong_key, other);
  EXPECT_EQ(f.accept(wrong_key, kHost, out), Verdict::kUnauthenticated);
  EXPECT_EQ(f.counters().unauthenticated, 2u);
  EXPECT_EQ(f.counters().malformed, 0u);
  EXPECT_EQ(out, command(7, 10));
  // Without a session, a forgery is not adopted either.
  f.release();
  EXPECT_EQ(f.accept(forged, kHost, out), Verdict::kUnauthenticated);
  EXPECT_FALSE(f.has_session());
}

// A recorded command sent again - the same bytes, MAC and all - is rejected: newest-only within the
// session (a window of one), from the right endpoint or not.
TEST(CommandFilter, RejectsReplayedCommands) {
  CommandFilter f(kKey);
  CommandPacket out;
  const Bytes first = encoded(command(7, 10, 0));
  const Bytes second = encoded(command(7, 11, kCommandEnable));
  ASSERT_EQ(f.accept(first, kHost, out), Verdict::kAccept);
  ASSERT_EQ(f.accept(second, kHost, out), Verdict::kAccept);
  EXPECT_EQ(f.accept(second, kHost, out), Verdict::kDuplicate);
  EXPECT_EQ(f.accept(first, kHost, out), Verdict::kStale);
  f.release();  // the watchdog fired: the released session cannot be revived by its own recording
  EXPECT_EQ(f.accept(first, kHost, out), Verdict::kStale);
  EXPECT_EQ(f.accept(second, kHost, out), Verdict::kDuplicate);
  EXPECT_FALSE(f.has_session());
}

// MAC under the key and an independent implementation (Python hashlib's keyed BLAKE2b): the golden
// packets' last 16 bytes.
TEST(MfbProtocol, MacIsKeyedBlake2bOfEverythingBeforeIt) {
  const auto mac = packet_mac(kKey, kGoldenCommand.data(), kCommandPacketSize - kMacSize);
  EXPECT_TRUE(std::equal(mac.begin(), mac.end(), kGoldenCommand.end() - static_cast<std::ptrdiff_t>(kMacSize)));
  LinkKey other = kKey;
  other.bytes[31] ^= 0x80;
  CommandPacket c;
  EXPECT_EQ(decode(kGoldenCommand, other, c), ParseError::kBadMac);
  StatePacket s;
  EXPECT_EQ(decode(kGoldenState, other, s), ParseError::kBadMac);
}

TEST(CommandFilter, ResetReturnsToPowerOnState) {
  CommandFilter f(kKey);
  CommandPacket out;
  ASSERT_EQ(f.accept(encoded(command(7, 500)), kHost, out), Verdict::kAccept);
  f.reset();
  EXPECT_FALSE(f.has_session());
  EXPECT_EQ(f.counters().accepted, 0u);
  EXPECT_EQ(f.accept(encoded(command(7, 1)), kHost, out), Verdict::kAccept);
}

// ---- OutputArming (board) -----------------------------------------------------------------------

TEST(OutputArming, OutputsStaySafeUntilAnEnableEdge) {
  OutputArming a;
  EXPECT_FALSE(a.outputs_enabled());
  EXPECT_EQ(a.status(), kStatusOutputsSafe);
  a.on_command(command(7, 1, kCommandEnable));  // enabled from the first command: no edge
  EXPECT_FALSE(a.outputs_enabled());
  a.on_command(command(7, 2, 0));
  EXPECT_FALSE(a.outputs_enabled());
  a.on_command(command(7, 3, kCommandEnable));
  EXPECT_TRUE(a.outputs_enabled());
  EXPECT_EQ(a.status(), 0);
  a.on_command(command(7, 4, 0));  // the host disables again
  EXPECT_FALSE(a.outputs_enabled());
}

TEST(OutputArming, WatchdogTripLatchesUntilHostAcknowledges) {
  OutputArming a;
  a.on_command(command(7, 1, 0));
  a.on_command(command(7, 2, kCommandEnable));
  ASSERT_TRUE(a.outputs_enabled());
  a.on_watchdog();  // while armed: a host loss too
  EXPECT_FALSE(a.outputs_enabled());
  EXPECT_EQ(a.status(), kStatusWatchdogTripped | kStatusOutputsSafe | kStatusHostLost);
  a.on_command(command(7, 50, kCommandEnable));  // a stalled host resuming as if nothing happened
  EXPECT_FALSE(a.outputs_enabled());
  EXPECT_EQ(a.status(), kStatusWatchdogTripped | kStatusOutputsSafe | kStatusHostLost);
  a.on_command(command(7, 51, 0));  // acknowledgement: trip latch cleared, outputs still safe
  EXPECT_EQ(a.status(), kStatusOutputsSafe | kStatusHostLost);  // the trip came while armed
  a.on_command(command(7, 52, kCommandEnable | kCommandOperatorArm));
  EXPECT_TRUE(a.outputs_enabled());
  EXPECT_EQ(a.status(), 0);
}

// A trip while disarmed (the host had disabled its outputs and ended) loses nobody's outputs: the
// next host arms with an ordinary edge.
TEST(OutputArming, TripWhileDisarmedIsNoHostLoss) {
  OutputArming a;
  a.on_command(command(7, 1, 0));
  a.on_watchdog();
  EXPECT_EQ(a.status(), kStatusWatchdogTripped | kStatusOutputsSafe);
  a.on_command(command(8, 1, 0));
  a.on_command(command(8, 2, kCommandEnable));
  EXPECT_TRUE(a.outputs_enabled());
}

// The host is killed while the outputs are armed; a new host session is adopted and makes the
// usual enable edge - once, twice, with the board's token: the outputs stay safe until the
// operator's arming (the edge with kCommandOperatorArm). Before, the edge alone re-armed them
// within 4 ms of the new session (issue 11: 2505 N).
TEST(OutputArming, NewSessionAfterHostLossStaysSafeUntilTheOperatorArms) {
  OutputArming a;
  a.set_token(0xA1);
  CommandPacket c = command(7, 1, 0);
  c.board_nonce = 0xA1;
  a.on_command(c);
  c = command(7, 2, kCommandEnable);
  c.board_nonce = 0xA1;
  a.on_command(c);
  ASSERT_TRUE(a.outputs_enabled());
  a.on_watchdog();  // the host is gone
  a.set_token(0xB2);  // the board adopts a new session
  for (std::uint32_t seq = 1; seq <= 6; seq += 2) {
    CommandPacket off = command(8, seq, 0), on = command(8, seq + 1, kCommandEnable);
    off.board_nonce = on.board_nonce = 0xB2;
    a.on_command(off);
    a.on_command(on);
    EXPECT_FALSE(a.outputs_enabled()) << "edge " << seq;
    EXPECT_EQ(a.status(), kStatusOutputsSafe | kStatusHostLost);
  }
  CommandPacket off = command(8, 7, 0), arm = command(8, 8, kCommandEnable | kCommandOperatorArm);
  off.board_nonce = arm.board_nonce = 0xB2;
  a.on_command(off);
  a.on_command(arm);
  EXPECT_TRUE(a.outputs_enabled());
  EXPECT_EQ(a.status(), 0);
}

// A session recorded and replayed later (its disable, its enable edge, even its operator's arming)
// is adopted again by a board without a session, but cannot arm it: the board drew a new token.
TEST(OutputArming, ReplayedEdgeWithAnOldTokenDoesNotArm) {
  OutputArming a;
  a.set_token(0xC3);
  CommandPacket off = command(9, 1, 0), on = command(9, 2, kCommandEnable | kCommandOperatorArm);
  off.board_nonce = on.board_nonce = 0xA1;  // the token of the session it was recorded in
  a.on_command(off);
  a.on_command(on);
  EXPECT_FALSE(a.outputs_enabled());
  on.board_nonce = 0xC3;
  on.sequence = 3;
  a.on_command(on);
  EXPECT_TRUE(a.outputs_enabled());
}

TEST(OutputArming, EstopForcesSafeOutputsAndNeedsEdgeAfterRelease) {
  OutputArming a;
  a.on_command(command(7, 1, 0));
  a.on_command(command(7, 2, kCommandEnable));
  a.set_estop(true);
  EXPECT_FALSE(a.outputs_enabled());
  EXPECT_EQ(a.status(), kStatusEstop | kStatusOutputsSafe);
  a.on_command(command(7, 3, 0));  // disabled during the e-stop does not count as the edge's start
  a.set_estop(false);
  a.on_command(command(7, 4, kCommandEnable));
  EXPECT_FALSE(a.outputs_enabled());
  a.on_command(command(7, 5, 0));
  a.on_command(command(7, 6, kCommandEnable));
  EXPECT_TRUE(a.outputs_enabled());
}

TEST(OutputArming, NewSessionDisarms) {
  OutputArming a;
  a.on_command(command(7, 1, 0));
  a.on_command(command(7, 2, kCommandEnable));
  ASSERT_TRUE(a.outputs_enabled());
  a.on_command(command(8, 1, kCommandEnable));
  EXPECT_FALSE(a.outputs_enabled());
  a.on_command(command(8, 2, 0));
  a.on_command(command(8, 3, kCommandEnable));
  EXPECT_TRUE(a.outputs_enabled());
}

}  // namespace
}  // namespace peha::mfb
