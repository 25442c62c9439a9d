// What the MFB link's authentication costs per packet (docs/mfb-protocol.md#authentication): the
// MAC alone (keyed BLAKE2b-128, libsodium), and encode (CRC + MAC) and decode (CRC + MAC check in
// constant time) of each packet type, against the same without the MAC (the CRC over the same
// bytes). Per control cycle the host encodes one command and decodes one state; the board the
// reverse.
#include "peha/mfb/protocol.hpp"

#include <benchmark/benchmark.h>

#include <array>

namespace {

using namespace peha::mfb;

LinkKey bench_key() {
  LinkKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(0xA5 ^ i);
  return k;
}

CommandPacket bench_command() {
  CommandPacket c;
  c.session_id = 0x1234567;
  c.sequence = 1;
  c.flags = kCommandEnable;
  for (std::size_t i = 0; i < c.da.size(); ++i) c.da[i] = static_cast<std::uint16_t>(30000 + i);
  return c;
}

StatePacket bench_state() {
  StatePacket s;
  s.session_id = 0x1234567;
  s.sequence = 1;
  for (std::size_t i = 0; i < s.ad.size(); ++i) s.ad[i] = static_cast<std::uint16_t>(20000 + 17 * i);
  return s;
}

template <std::size_t kSize>
void mac_only(benchmark::State& state) {
  const LinkKey key = bench_key();
  std::array<std::uint8_t, kSize - kMacSize> bytes{};
  for (auto _ : state) {
    bytes[12] = static_cast<std::uint8_t>(bytes[12] + 1);
    auto mac = packet_mac(key, bytes.data(), bytes.size());
    benchmark::DoNotOptimize(mac);
  }
}

template <std::size_t kSize>
void crc_only(benchmark::State& state) {
  std::array<std::uint8_t, kSize - kTrailerSize> bytes{};
  for (auto _ : state) {
    bytes[12] = static_cast<std::uint8_t>(bytes[12] + 1);
    benchmark::DoNotOptimize(crc32c(bytes.data(), bytes.size()));
  }
}

void BM_MfbMacCommand(benchmark::State& state) { mac_only<kCommandPacketSize>(state); }
void BM_MfbMacState(benchmark::State& state) { mac_only<kStatePacketSize>(state); }
void BM_MfbCrcCommand(benchmark::State& state) { crc_only<kCommandPacketSize>(state); }
void BM_MfbCrcState(benchmark::State& state) { crc_only<kStatePacketSize>(state); }

void BM_MfbEncodeCommand(benchmark::State& state) {
  const LinkKey key = bench_key();
  CommandPacket c = bench_command();
  std::array<std::uint8_t, kMaxPacketSize> bytes{};
  for (auto _ : state) {
    ++c.sequence;
    benchmark::DoNotOptimize(encode(c, key, bytes));
  }
}

void BM_MfbDecodeCommand(benchmark::State& state) {
  const LinkKey key = bench_key();
  std::array<std::uint8_t, kMaxPacketSize> bytes{};
  const std::size_t n = encode(bench_command(), key, bytes);
  CommandPacket c;
  for (auto _ : state) {
    if (decode(std::span(bytes).first(n), key, c) != ParseError::kOk) state.SkipWithError("decode failed");
    benchmark::DoNotOptimize(c);
  }
}

void BM_MfbEncodeState(benchmark::State& state) {
  const LinkKey key = bench_key();
  StatePacket s = bench_state();
  std::array<std::uint8_t, kMaxPacketSize> bytes{};
  for (auto _ : state) {
    ++s.sequence;
    benchmark::DoNotOptimize(encode(s, key, bytes));
  }
}

void BM_MfbDecodeState(benchmark::State& state) {
  const LinkKey key = bench_key();
  std::array<std::uint8_t, kMaxPacketSize> bytes{};
  const std::size_t n = encode(bench_state(), key, bytes);
  StatePacket s;
  for (auto _ : state) {
    if (decode(std::span(bytes).first(n), key, s) != ParseError::kOk) state.SkipWithError("decode failed");
    benchmark::DoNotOptimize(s);
  }
}

/// A forged state packet (its MAC flipped): rejected after the CRC and the full MAC computation,
/// so a flood of forgeries costs the host this much per datagram.
void BM_MfbRejectForgedState(benchmark::State& state) {
  const LinkKey key = bench_key();
  std::array<std::uint8_t, kMaxPacketSize> bytes{};
  const std::size_t n = encode(bench_state(), key, bytes);
  bytes[n - 1] ^= 1;
  StatePacket s;
  for (auto _ : state) {
    if (decode(std::span(bytes).first(n), key, s) != ParseError::kBadMac) state.SkipWithError("forgery accepted");
    benchmark::DoNotOptimize(s);
  }
}

BENCHMARK(BM_MfbMacCommand);
BENCHMARK(BM_MfbMacState);
BENCHMARK(BM_MfbCrcCommand);
BENCHMARK(BM_MfbCrcState);
BENCHMARK(BM_MfbEncodeCommand);
BENCHMARK(BM_MfbDecodeCommand);
BENCHMARK(BM_MfbEncodeState);
BENCHMARK(BM_MfbDecodeState);
BENCHMARK(BM_MfbRejectForgedState);

}  // namespace
