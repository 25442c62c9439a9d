#pragma once
// The failed figures of a verdict, for tests that assert which figures fail (and that no other does).
#include "peha/safety/verdict.hpp"

#include <string>
#include <vector>

namespace peha::testing {

inline std::vector<std::string> failed_figures(const safety::Verdict& v) {
  std::vector<std::string> failed;
  for (const safety::Check& c : v.checks) {
    if (!c.passed()) failed.push_back(c.figure);
  }
  return failed;
}

/// True when the verdict has a failed check whose figure contains `part`.
inline bool fails_on(const safety::Verdict& v, const std::string& part) {
  for (const safety::Check& c : v.checks) {
    if (!c.passed() && c.figure.find(part) != std::string::npos) return true;
  }
  return false;
}

/// True when a check whose figure contains `part` exists (the figure is judged at all).
inline bool judges(const safety::Verdict& v, const std::string& part) {
  for (const safety::Check& c : v.checks) {
    if (c.figure.find(part) != std::string::npos) return true;
  }
  return false;
}

}  // namespace peha::testing
