#pragma once
// The link key of the fuzz target and its seed corpus (fuzz/make_mfb_corpus.cpp): fixed, so the
// committed seeds carry valid MACs and mutations start from authentic packets.
#include "peha/mfb/protocol.hpp"

inline peha::mfb::LinkKey fuzz_key() {
  peha::mfb::LinkKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(7 * i + 3);
  return k;
}
