// The MFB protocol runs inside the control loop (STYLE.md principle 3): encoding, decoding and both
// filters allocate nothing, for valid and malformed datagrams alike.
#include "peha/mfb/protocol.hpp"

#include "../support/alloc_counter.hpp"

#include <gtest/gtest.h>

namespace peha::mfb {
namespace {

TEST(MfbProtocol, EncodeDecodeAndFiltersAllocateNothing) {
  std::array<std::uint8_t, kMaxPacketSize> command_bytes{};
  std::array<std::uint8_t, kMaxPacketSize> state_bytes{};
  StateFilter state_filter(42);
  CommandFilter command_filter;
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
      const std::size_t cn = encode(command, command_bytes);
      const std::size_t sn = encode(state, state_bytes);
      if (k % 7 == 0) state_bytes[k % sn] ^= 0x01;  // some malformed ones too
      CommandPacket c;
      if (command_filter.accept(std::span(command_bytes).first(cn), c) == Verdict::kAccept) {
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
