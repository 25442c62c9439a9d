#pragma once
/// \file
/// A log row's columns by name: a block of columns is a struct of doubles declared in the log's
/// column order (its members named as the columns), filled with designated initializers, so the
/// compiler checks the order the columns list gives and no value lands in its neighbour's column.

#include <array>
#include <bit>
#include <cstddef>
#include <span>
#include <type_traits>

namespace peha::experiments {

/// A block's values in column order: `block` is a struct of doubles only.
template <class Block>
std::array<double, sizeof(Block) / sizeof(double)> as_columns(const Block& block) noexcept {
  constexpr std::size_t n = sizeof(Block) / sizeof(double);
  static_assert(std::is_trivially_copyable_v<Block> && sizeof(Block) == n * sizeof(double), "a block of log columns is doubles only");
  return std::bit_cast<std::array<double, n>>(block);
}

/// Copies `block` into `row` from column `c` on and moves `c` past it. Allocation-free: called from
/// the control loop.
template <class Block>
void put_columns(std::span<double> row, std::size_t& c, const Block& block) noexcept {
  for (const double v : as_columns(block)) row[c++] = v;
}

}  // namespace peha::experiments
