#pragma once
// A config text with one edit, for the tests that check how a changed file is read or refused.
#include <string>

#include <gtest/gtest.h>

namespace peha::testing {

/// `text` with the first `from` replaced by `to`; a `from` that is not there fails the test (the edit
/// would silently test the shipped text) and leaves `text` as it is.
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace peha::testing
