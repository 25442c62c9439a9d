#include "peha/runtime/lifecycle.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace peha::runtime {
namespace {

using S = LifecycleState;
using T = Transition;

constexpr S kStates[] = {S::kUnconfigured, S::kInactive, S::kActive, S::kFault, S::kRecovering, S::kFinalized};
constexpr T kTransitions[] = {T::kConfigure, T::kActivate, T::kDeactivate, T::kFault,
                              T::kRecover,   T::kRecovered, T::kShutdown};

struct Allowed {
  S from;
  T transition;
  S to;
};

// The specification, written out independently of next_state(): every other pair is forbidden.
constexpr Allowed kAllowed[] = {
    {S::kUnconfigured, T::kConfigure, S::kInactive},
    {S::kInactive, T::kActivate, S::kActive},
    {S::kActive, T::kDeactivate, S::kInactive},
    {S::kInactive, T::kFault, S::kFault},
    {S::kActive, T::kFault, S::kFault},
    {S::kRecovering, T::kFault, S::kFault},
    {S::kFault, T::kRecover, S::kRecovering},
    {S::kRecovering, T::kRecovered, S::kInactive},
    {S::kUnconfigured, T::kShutdown, S::kFinalized},
    {S::kInactive, T::kShutdown, S::kFinalized},
    {S::kActive, T::kShutdown, S::kFinalized},
    {S::kFault, T::kShutdown, S::kFinalized},
    {S::kRecovering, T::kShutdown, S::kFinalized},
};

// Drives a fresh lifecycle into `target` along allowed transitions.
Lifecycle in_state(S target) {
  Lifecycle lc;
  auto go = [&](T t) { EXPECT_TRUE(lc.apply(t, 0.0, "setup")); };
  switch (target) {
    case S::kUnconfigured: break;
    case S::kInactive: go(T::kConfigure); break;
    case S::kActive: go(T::kConfigure); go(T::kActivate); break;
    case S::kFault: go(T::kConfigure); go(T::kFault); break;
    case S::kRecovering: go(T::kConfigure); go(T::kFault); go(T::kRecover); break;
    case S::kFinalized: go(T::kShutdown); break;
  }
  EXPECT_EQ(lc.state(), target);
  return lc;
}

// All 6 x 7 (state, transition) pairs: the 13 allowed ones lead where the table says and are
// recorded; the other 29 return false and leave state and history untouched.
TEST(Lifecycle, AllowsExactlyTheSpecifiedTransitions) {
  int allowed = 0, forbidden = 0;
  for (S from : kStates) {
    for (T t : kTransitions) {
      const Allowed* spec = nullptr;
      for (const Allowed& a : kAllowed) {
        if (a.from == from && a.transition == t) spec = &a;
      }
      Lifecycle lc = in_state(from);
      const std::uint64_t before = lc.transitions();
      const bool applied = lc.apply(t, 1.5, "under test");
      SCOPED_TRACE(std::string(to_string(from)) + " --" + to_string(t) + "-->");
      if (spec) {
        ++allowed;
        EXPECT_TRUE(applied);
        EXPECT_EQ(lc.state(), spec->to);
        ASSERT_EQ(lc.transitions(), before + 1);
        const LifecycleEvent& e = lc.history(lc.history_size() - 1);
        EXPECT_EQ(e.from, from);
        EXPECT_EQ(e.to, spec->to);
        EXPECT_EQ(e.transition, t);
        EXPECT_EQ(e.t_s, 1.5);
        EXPECT_STREQ(e.reason, "under test");
        EXPECT_EQ(next_state(from, t), spec->to);
      } else {
        ++forbidden;
        EXPECT_FALSE(applied);
        EXPECT_EQ(lc.state(), from);
        EXPECT_EQ(lc.transitions(), before);
        EXPECT_FALSE(next_state(from, t).has_value());
      }
    }
  }
  EXPECT_EQ(allowed, 13);
  EXPECT_EQ(forbidden, 29);
}

// Recovery is a real path: fault -> recovering -> inactive -> active again.
TEST(Lifecycle, RecoversFromAFaultBackToActive) {
  Lifecycle lc;
  EXPECT_TRUE(lc.apply(T::kConfigure, 0.0, "config loaded"));
  EXPECT_TRUE(lc.apply(T::kActivate, 0.1, "operator start"));
  EXPECT_TRUE(lc.apply(T::kFault, 2.0, "watchdog expired"));
  EXPECT_FALSE(lc.apply(T::kActivate, 2.1, "must not skip recovery"));
  EXPECT_FALSE(lc.apply(T::kFault, 2.2, "second fault"));  // the first cause stays in the history
  EXPECT_TRUE(lc.apply(T::kRecover, 5.0, "operator: recover"));
  EXPECT_TRUE(lc.apply(T::kRecovered, 5.5, "pressures vented, sensors valid"));
  EXPECT_TRUE(lc.apply(T::kActivate, 6.0, "operator start"));
  EXPECT_EQ(lc.state(), S::kActive);
  const std::string text = lc.describe_history();
  EXPECT_NE(text.find("t=2.000 s  active -> fault (fault): watchdog expired"), std::string::npos) << text;
  EXPECT_EQ(text.find("second fault"), std::string::npos);
}

TEST(Lifecycle, KeepsTheLatestTransitionsAndTruncatesLongReasons) {
  Lifecycle lc;
  lc.apply(T::kConfigure, 0.0, nullptr);
  for (int k = 0; k < 100; ++k) {
    lc.apply(T::kActivate, 2.0 * k + 1, "a");
    lc.apply(T::kDeactivate, 2.0 * k + 2, "d");
  }
  EXPECT_EQ(lc.transitions(), 201u);
  ASSERT_EQ(lc.history_size(), Lifecycle::kHistory);
  EXPECT_EQ(lc.history(Lifecycle::kHistory - 1).t_s, 200.0);  // the latest
  EXPECT_EQ(lc.history(0).t_s, 200.0 - (Lifecycle::kHistory - 1));

  const std::string long_reason(300, 'x');
  lc.apply(T::kShutdown, 201.0, long_reason.c_str());
  EXPECT_EQ(std::strlen(lc.history(Lifecycle::kHistory - 1).reason), LifecycleEvent::kMaxReasonChars);
  EXPECT_EQ(lc.state(), S::kFinalized);
  EXPECT_FALSE(lc.apply(T::kShutdown, 202.0, "finalized is terminal"));
}

TEST(Lifecycle, NamesEveryStateAndTransition) {
  EXPECT_STREQ(to_string(S::kUnconfigured), "unconfigured");
  EXPECT_STREQ(to_string(S::kInactive), "inactive");
  EXPECT_STREQ(to_string(S::kActive), "active");
  EXPECT_STREQ(to_string(S::kFault), "fault");
  EXPECT_STREQ(to_string(S::kRecovering), "recovering");
  EXPECT_STREQ(to_string(S::kFinalized), "finalized");
  EXPECT_STREQ(to_string(T::kConfigure), "configure");
  EXPECT_STREQ(to_string(T::kRecovered), "recovered");
  EXPECT_STREQ(to_string(T::kShutdown), "shutdown");
}

}  // namespace
}  // namespace peha::runtime
