#pragma once
// Counts heap allocations made by this process (global operator new is replaced in
// alloc_counter.cpp). Used to prove that control steps do not allocate.
#include <cstddef>

namespace peha::testing {

/// Number of calls to operator new so far.
std::size_t allocation_count() noexcept;

/// Allocations made while `fn` runs.
template <typename Fn>
std::size_t allocations_during(Fn&& fn) {
  const std::size_t before = allocation_count();
  fn();
  return allocation_count() - before;
}

}  // namespace peha::testing
