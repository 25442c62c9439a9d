// Writes the seed corpus of fuzz/mfb_packet_fuzz.cpp: a few valid packets of each type (the fuzzer
// mutates from there) and one hand-made script. The committed files in fuzz/corpus/mfb_packet/
// were made with
//   g++ -std=c++20 -I include src/mfb/protocol.cpp fuzz/make_mfb_corpus.cpp -lsodium -o /tmp/make_mfb_corpus
//   /tmp/make_mfb_corpus fuzz/corpus/mfb_packet
#include "peha/mfb/protocol.hpp"
#include "fuzz_key.hpp"

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace peha::mfb;

void write(const std::string& dir, const std::string& name, const std::uint8_t* data, std::size_t size) {
  std::ofstream f(dir + "/" + name, std::ios::binary);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!f) std::fprintf(stderr, "cannot write %s/%s\n", dir.c_str(), name.c_str());
}

template <typename Packet>
void write_packet(const std::string& dir, const std::string& name, const Packet& p) {
  std::uint8_t buf[kMaxPacketSize];
  write(dir, name, buf, encode(p, fuzz_key(), buf));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <corpus directory>\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];

  CommandPacket c;
  c.session_id = 0x11223344;
  c.sequence = 1;
  write_packet(dir, "command_disabled", c);
  c.sequence = 0xFFFFFFFF;
  c.host_time_ns = 1'000'000'123;
  c.da = {0, 1, 2, 0x7FFF, 0x8000, 0xFFFE, 0xFFFF, 12345};
  c.digital_out = 0xA5;
  c.flags = kCommandEnable;
  write_packet(dir, "command_enabled", c);

  StatePacket s;
  s.session_id = 0x11223344;
  s.sequence = 7;
  s.status = kStatusOutputsSafe;
  write_packet(dir, "state_safe", s);
  s.sequence = 0x80000000;
  s.ack_sequence = 0xFFFFFFFF;
  s.echo_host_time_ns = 1'000'000'123;
  s.board_time_ns = 42'000'000'000;
  for (std::size_t i = 0; i < s.ad.size(); ++i) s.ad[i] = static_cast<std::uint16_t>(4096 * i + 7);
  s.encoder = {-1, 1, 0x7FFFFFFF, -0x7FFFFFFF - 1, 100000, -100000, 0, 3};
  s.digital_in = 0x3C;
  s.status = kStatusWatchdogTripped | kStatusOutputsSafe | kStatusNoSession;
  write_packet(dir, "state_tripped", s);

  // A script (see mfb_packet_fuzz.cpp): a host session, in-order, duplicate, stale and gapped
  // states, then a board that adopts, arms by an enable edge, trips and is taken over.
  const std::vector<std::uint8_t> script = {
      0x01, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // state, session A, +1
      0x01, 0x01, 0x00, 0, 0x02, 0, 0, 0,  // state +1, outputs safe
      0x01, 0x00, 0x00, 0, 0x00, 0, 0, 0,  // duplicate
      0x01, 0xFF, 0xFF, 0, 0x00, 0, 0, 0,  // stale (-1)
      0x01, 0x05, 0x00, 0, 0x00, 0, 0, 0,  // gap of 4
      0x41, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // foreign session
      0x05, 0x01, 0x00, 9, 0x00, 3, 0, 0,  // corrupt
      0x00, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // foreign source
      0x10, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // command session A, disabled: adopted
      0x10, 0x01, 0x00, 0, 0x01, 0, 0, 0,  // enabled: armed
      0x50, 0x01, 0x00, 0, 0x01, 0, 0, 0,  // session B: foreign
      0x58, 0x01, 0x00, 0, 0x01, 0, 0, 0,  // watchdog, then session B adopted (enabled: no edge)
      0x50, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // B disabled: acknowledges
      0x50, 0x01, 0x00, 0, 0x01, 0, 0, 0,  // B enabled: armed
      0x70, 0x01, 0x00, 0, 0x01, 1, 0, 0,  // e-stop pressed
      0x70, 0x01, 0x00, 0, 0x00, 0, 0, 0,  // e-stop released, disabled
      0x10, 0x01, 0x00, 0, 0x81, 0, 0, 0,  // unknown flag bit: malformed
  };
  write(dir, "script_sessions", script.data(), script.size());
  return 0;
}
