#pragma once
/// \file
/// A bounded lock-free queue between exactly one producer thread and exactly one consumer thread:
/// how the real-time loop hands rows and samples to its non-real-time helpers (the CSV writer, the
/// telemetry sender) without ever blocking or allocating.
///
/// Head and tail are monotonically increasing counters (masked into the slot array), published with
/// release and read with acquire, so a slot's contents are visible before its index. Each side keeps
/// a private copy of the other side's counter and refreshes it only when the ring looks full (for
/// the producer) or empty (for the consumer); the two sides' counters sit on separate cache lines.

#include <atomic>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace peha::runtime {

/// Cache-line size used for padding (x86-64 and most ARM64 cores).
inline constexpr std::size_t kCacheLineBytes = 64;

template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing copies slots with plain assignment");
  static_assert(std::is_default_constructible_v<T>, "SpscRing preallocates default-constructed slots");

 public:
  /// `capacity`: number of slots, a power of two (>= 1). Allocates all slots here, never later.
  /// Throws std::invalid_argument otherwise.
  explicit SpscRing(std::size_t capacity) : capacity_(checked(capacity)), mask_(capacity - 1),
                                            slots_(std::make_unique<T[]>(capacity)) {}
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  std::size_t capacity() const noexcept { return capacity_; }

  /// Producer only. Copies `value` into the ring; returns false (and changes nothing) when full.
  bool try_push(const T& value) noexcept {
    return try_push_with([&value](T& slot) noexcept { slot = value; });
  }

  /// Producer only. Lets `fill(T&)` write the next free slot in place (saves a copy of large
  /// slots); returns false without calling it when the ring is full. `fill` must be noexcept.
  template <class Fill>
  bool try_push_with(Fill&& fill) noexcept {
    const std::size_t head = producer_.index.load(std::memory_order_relaxed);
    if (head - producer_.cached_other == capacity_) {
      producer_.cached_other = consumer_.index.load(std::memory_order_acquire);
      if (head - producer_.cached_other == capacity_) return false;
    }
    fill(slots_[head & mask_]);
    producer_.index.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer only. Moves the oldest element into `out`; returns false when empty.
  bool try_pop(T& out) noexcept {
    const std::size_t tail = consumer_.index.load(std::memory_order_relaxed);
    if (tail == consumer_.cached_other) {
      consumer_.cached_other = producer_.index.load(std::memory_order_acquire);
      if (tail == consumer_.cached_other) return false;
    }
    out = slots_[tail & mask_];
    consumer_.index.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Number of elements in the ring at some instant during the call (either thread, or a third).
  std::size_t size_approx() const noexcept {
    // Tail first: the head read afterwards is at least as new, so the difference is never negative.
    const std::size_t tail = consumer_.index.load(std::memory_order_acquire);
    const std::size_t head = producer_.index.load(std::memory_order_acquire);
    const std::size_t n = head - tail;
    return n < capacity_ ? n : capacity_;
  }

 private:
  static std::size_t checked(std::size_t capacity) {
    if (capacity == 0 || (capacity & (capacity - 1)) != 0) {
      throw std::invalid_argument("SpscRing: capacity must be a power of two, got " + std::to_string(capacity));
    }
    return capacity;
  }

  /// One side's own counter plus its private copy of the other side's, alone on a cache line.
  struct alignas(kCacheLineBytes) Side {
    std::atomic<std::size_t> index{0};  ///< head (producer) or tail (consumer): elements pushed/popped
    std::size_t cached_other = 0;       ///< last seen value of the other side's index
  };

  const std::size_t capacity_;
  const std::size_t mask_;
  std::unique_ptr<T[]> slots_;
  Side producer_;
  Side consumer_;
};

}  // namespace peha::runtime
