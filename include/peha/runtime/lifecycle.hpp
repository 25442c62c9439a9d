#pragma once
/// \file
/// The named states of a run and the only transitions between them (after ros2_control's hardware
/// lifecycle, with recovery from a fault as a real path rather than a dead end):
///
///                 configure            activate
///  unconfigured ----------> inactive ----------> active
///                            |   ^   <----------   |
///                            |   |   deactivate    |
///                      fault |   | recovered       | fault
///                            |   |                 |
///                            |  recovering         |
///                            |   ^     |           |
///                            |   |     | fault     |
///                            |   | recover         |
///                            v   |     v           v
///                           +------------------------+
///                           |         fault          |
///                           +------------------------+
///
///  shutdown: every state except finalized --> finalized (terminal)
///
/// Recovery is operator-driven: `kRecover` is applied only on an explicit operator command (never
/// automatically by the loop), after the cause has been looked at. `kRecovered` returns to
/// inactive, never straight to active: the runner re-activates and it is the runner's job to ramp
/// the pressures back from the vented state rather than step them. A second fault while in fault
/// is refused, so the history keeps the first cause.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace peha::runtime {

enum class LifecycleState { kUnconfigured, kInactive, kActive, kFault, kRecovering, kFinalized };
enum class Transition { kConfigure, kActivate, kDeactivate, kFault, kRecover, kRecovered, kShutdown };


const char* to_string(LifecycleState state) noexcept;  ///< "unconfigured", "inactive", ...
const char* to_string(Transition transition) noexcept;  ///< "configure", "activate", ...

/// The transition table: the state `transition` leads to from `from`, or nullopt if not allowed.
std::optional<LifecycleState> next_state(LifecycleState from, Transition transition) noexcept;

/// One applied transition, for the log and the post-mortem.
struct LifecycleEvent {
  static constexpr std::size_t kMaxReasonChars = 95;
  double t_s = 0;  ///< loop time of the transition
  LifecycleState from = LifecycleState::kUnconfigured;
  LifecycleState to = LifecycleState::kUnconfigured;
  Transition transition = Transition::kConfigure;
  char reason[kMaxReasonChars + 1] = {};  ///< copied, truncated
};

/// The current state plus the last kHistory applied transitions. Loop-safe: no allocation, noexcept.
class Lifecycle {
 public:
  static constexpr std::size_t kHistory = 32;

  LifecycleState state() const noexcept { return state_; }
  /// Applies `transition` if the table allows it from the current state and records it with
  /// `t_s` and `reason` (may be null). Returns false, and changes nothing, if it is not allowed.
  bool apply(Transition transition, double t_s, const char* reason) noexcept;

  std::uint64_t transitions() const noexcept { return applied_; }  ///< applied since construction
  std::size_t history_size() const noexcept;                       ///< min(transitions(), kHistory)
  /// `i` = 0 is the oldest transition kept, history_size() - 1 the latest.
  const LifecycleEvent& history(std::size_t i) const noexcept;
  /// The kept history, one line per transition: "t=1.234 s  inactive -> active (activate): reason".
  std::string describe_history() const;

 private:
  LifecycleState state_ = LifecycleState::kUnconfigured;
  std::array<LifecycleEvent, kHistory> events_{};
  std::uint64_t applied_ = 0;
};

/// The kept history of `lifecycle`, oldest first (after a run: its faults and recoveries).
std::vector<LifecycleEvent> history_of(const Lifecycle& lifecycle);

}  // namespace peha::runtime
