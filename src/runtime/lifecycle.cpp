#include "peha/runtime/lifecycle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace peha::runtime {

const char* to_string(LifecycleState state) noexcept {
  switch (state) {
    case LifecycleState::kUnconfigured: return "unconfigured";
    case LifecycleState::kInactive: return "inactive";
    case LifecycleState::kActive: return "active";
    case LifecycleState::kFault: return "fault";
    case LifecycleState::kRecovering: return "recovering";
    case LifecycleState::kFinalized: return "finalized";
  }
  return "invalid";
}

const char* to_string(Transition transition) noexcept {
  switch (transition) {
    case Transition::kConfigure: return "configure";
    case Transition::kActivate: return "activate";
    case Transition::kDeactivate: return "deactivate";
    case Transition::kFault: return "fault";
    case Transition::kRecover: return "recover";
    case Transition::kRecovered: return "recovered";
    case Transition::kShutdown: return "shutdown";
  }
  return "invalid";
}

std::optional<LifecycleState> next_state(LifecycleState from, Transition transition) noexcept {
  using S = LifecycleState;
  switch (transition) {
    case Transition::kConfigure:
      if (from == S::kUnconfigured) return S::kInactive;
      break;
    case Transition::kActivate:
      if (from == S::kInactive) return S::kActive;
      break;
    case Transition::kDeactivate:
      if (from == S::kActive) return S::kInactive;
      break;
    case Transition::kFault:
      if (from == S::kInactive || from == S::kActive || from == S::kRecovering) return S::kFault;
      break;
    case Transition::kRecover:
      if (from == S::kFault) return S::kRecovering;
      break;
    case Transition::kRecovered:
      if (from == S::kRecovering) return S::kInactive;
      break;
    case Transition::kShutdown:
      if (from != S::kFinalized) return S::kFinalized;
      break;
  }
  return std::nullopt;
}

bool Lifecycle::apply(Transition transition, double t_s, const char* reason) noexcept {
  const std::optional<LifecycleState> to = next_state(state_, transition);
  if (!to) return false;
  LifecycleEvent& e = events_[applied_ % kHistory];
  e.t_s = t_s;
  e.from = state_;
  e.to = *to;
  e.transition = transition;
  const std::size_t n = reason ? strnlen(reason, LifecycleEvent::kMaxReasonChars) : 0;
  if (n) std::memcpy(e.reason, reason, n);
  e.reason[n] = '\0';
  state_ = *to;
  ++applied_;
  return true;
}

std::size_t Lifecycle::history_size() const noexcept {
  return static_cast<std::size_t>(std::min<std::uint64_t>(applied_, kHistory));
}

const LifecycleEvent& Lifecycle::history(std::size_t i) const noexcept {
  const std::uint64_t oldest = applied_ - history_size();
  return events_[(oldest + i) % kHistory];
}

std::vector<LifecycleEvent> history_of(const Lifecycle& lifecycle) {
  std::vector<LifecycleEvent> events;
  for (std::size_t i = 0; i < lifecycle.history_size(); ++i) events.push_back(lifecycle.history(i));
  return events;
}

std::string Lifecycle::describe_history() const {
  std::string out;
  for (std::size_t i = 0; i < history_size(); ++i) {
    const LifecycleEvent& e = history(i);
    out += fmt::format("t={:.3f} s  {} -> {} ({}){}{}\n", e.t_s, to_string(e.from), to_string(e.to),
                       to_string(e.transition), e.reason[0] ? ": " : "", e.reason);
  }
  return out;
}

}  // namespace peha::runtime
