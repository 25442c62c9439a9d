#include "peha/runtime/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <thread>

namespace peha::runtime {
namespace {

TEST(SpscRing, RejectsACapacityThatIsNotAPowerOfTwo) {
  EXPECT_THROW(SpscRing<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(3), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(1000), std::invalid_argument);
  EXPECT_NO_THROW(SpscRing<int>(1));
  EXPECT_NO_THROW(SpscRing<int>(1024));
}

TEST(SpscRing, HoldsExactlyItsCapacityAndRefusesMore) {
  SpscRing<int> ring(4);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(ring.try_push(i));
  EXPECT_FALSE(ring.try_push(99));
  EXPECT_EQ(ring.size_approx(), 4u);
  int out = -1;
  EXPECT_TRUE(ring.try_pop(out));
  EXPECT_EQ(out, 0);
  EXPECT_TRUE(ring.try_push(4));  // a freed slot is usable again
  for (int expected = 1; expected <= 4; ++expected) {
    ASSERT_TRUE(ring.try_pop(out));
    EXPECT_EQ(out, expected);
  }
  EXPECT_FALSE(ring.try_pop(out));
  EXPECT_EQ(ring.size_approx(), 0u);
}

// Many laps around a small ring: the masked indices wrap without losing or reordering anything.
TEST(SpscRing, StaysInOrderAcrossManyWrapArounds) {
  SpscRing<std::uint64_t> ring(8);
  std::uint64_t next_in = 0, next_out = 0;
  for (int lap = 0; lap < 1000; ++lap) {
    for (int k = 0; k < 5; ++k) ASSERT_TRUE(ring.try_push(next_in++));
    std::uint64_t v;
    for (int k = 0; k < 5; ++k) {
      ASSERT_TRUE(ring.try_pop(v));
      ASSERT_EQ(v, next_out++);
    }
  }
  EXPECT_EQ(next_out, 5000u);
}

TEST(SpscRing, FillsSlotsInPlace) {
  struct Wide {
    std::uint64_t seq;
    double values[8];
  };
  SpscRing<Wide> ring(2);
  EXPECT_TRUE(ring.try_push_with([](Wide& w) noexcept {
    w.seq = 7;
    w.values[3] = 2.5;
  }));
  Wide out{};
  ASSERT_TRUE(ring.try_pop(out));
  EXPECT_EQ(out.seq, 7u);
  EXPECT_EQ(out.values[3], 2.5);
}

// A producer and a consumer thread (the real use; run under TSan too): 10^6 values pass through a
// 64-slot ring, every one exactly once and in order, although the ring is full or empty often.
TEST(SpscRing, PassesEveryValueInOrderBetweenTwoThreads) {
  constexpr std::uint64_t kCount = 1'000'000;
  SpscRing<std::uint64_t> ring(64);
  std::uint64_t refused = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount;) {
      if (ring.try_push(i)) {
        ++i;
      } else {
        ++refused;
        std::this_thread::yield();
      }
    }
  });
  std::uint64_t expected = 0, out_of_order = 0;
  while (expected < kCount) {
    std::uint64_t v;
    if (!ring.try_pop(v)) {
      std::this_thread::yield();
      continue;
    }
    if (v != expected) ++out_of_order;
    expected = v + 1;
  }
  producer.join();
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(expected, kCount);
  std::uint64_t v;
  EXPECT_FALSE(ring.try_pop(v));
}

}  // namespace
}  // namespace peha::runtime
