// The MFB protocol runs inside the control loop (STYLE.md principle 3): encoding, decoding and both
// filters allocate nothing (the MAC included), for valid, malformed and forged datagrams alike.
#include "peha/mfb/protocol.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

namespace peha::mfb {
namespace {

TEST(MfbProtocol, EncodeDecodeAndFiltersAllocateNothing) {
  std::array<std::uint8_t, kMaxPacketSize> command_bytes{};
  std::array<std::uint8_t, kMaxPacketSize> state_bytes{};
  LinkKey key;
  key.bytes.fill(0x5A);
  StateFilter state_filter(42, key);
  CommandFilter command_filter(key);
  const Source host{0x7F000001u, 5000};
  OutputArming arming;
  CommandPacket command;
  command.session_id = 42;
  StatePacket state;
  state.session_id = 42;
  const std::size_t n = testing::allocations_during([&] {
    for (std::uint32_t k = 0; k < 10000; ++k) {
      command.sequence = k;
      command.flags = k % 2 ? kCommandEnable : 0;
      state.sequence = k;
      const std::size_t cn = encode(command, key, command_bytes);
      const std::size_t sn = encode(state, key, state_bytes);
      if (k % 7 == 0) state_bytes[k % sn] ^= 0x01;  // some malformed ones too (and forged: a flip in the MAC)
      CommandPacket c;
      if (command_filter.accept(std::span(command_bytes).first(cn), host, c) == Verdict::kAccept) {
        arming.on_command(c);
      }
      StatePacket s;
      state_filter.accept(std::span(state_bytes).first(sn), k % 11 != 0, s);
    }
  });
  EXPECT_EQ(n, 0u);
  EXPECT_GT(state_filter.counters().accepted, 0u);
  EXPECT_EQ(command_filter.counters().accepted, 10000u);
}

}  // namespace
}  // namespace peha::mfb
