#pragma once
/// \file
/// One simulated body behind several emulated boards (`peha mfb-emulator` for a scenario on several
/// boards, docs/channel-maps.md): each board's BoardEmulator runs in its own thread with its own
/// socket, key, session and watchdog, and sees the plant through a view of its joints
/// (SharedPlant::view). The plant stays one physical simulation of the whole body (one MuJoCo
/// model): it steps once per host cycle with every board's command of that cycle, and every board
/// then replies with the sample after that step, as the in-process run sees it.
///
/// A host cycle is recognised by the commands' host send times (`CommandPacket::host_time_ns`,
/// given by `note_command` before each step): the host sends all boards their commands within
/// microseconds, so commands less than half a period apart are one cycle. The cycle steps when every
/// live board (one that had a command within 4 `wait_s`) has written; a newer cycle's first command,
/// or `wait_s`, closes a cycle a board missed (a lost command: the step goes on with that board's
/// last outputs); that board's command, should it come after all, is kept for the next step and
/// opens no cycle of its own. Free-running steps (no host) come from board 0 alone while no board is live, so
/// the body runs on one period per period of wall time. A new session on any board (the host
/// connecting) restarts the whole body in its initial state.
#include "peha/io/backend.hpp"
#include "peha/mfb/protocol.hpp"

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace peha::mfb {

class SharedPlant : public std::enable_shared_from_this<SharedPlant> {
 public:
  /// `make_plant` builds the whole body in its initial state; `parts` boards share it; control
  /// period `period_s`; a cycle waits at most `wait_s` for the live boards that have not written.
  static std::shared_ptr<SharedPlant> create(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double period_s,
                                             double wait_s);

  /// What board `part` drives and senses: io joints `io_index` (its joint k = io joint io_index[k]).
  /// Restarts the body (a board's new session): pass it as the board's `make_plant`.
  std::unique_ptr<io::Backend> view(int part, const std::vector<int>& io_index);

  /// Board `part`'s next write applies `command` (its host cycle), or is free-running (nullptr):
  /// its BoardEmulator's step hook.
  void note_command(int part, const CommandPacket* command) noexcept;

  /// Steps the body taken (for the emulator's report).
  std::uint64_t steps() const;
  /// Host cycles stepped without every live board's command (a command lost or later than wait_s).
  std::uint64_t partial_steps() const;

  // Called by the views (under the lock).
  void write(int part, const std::vector<int>& io_index, const io::Command& command) noexcept;
  void read(const std::vector<int>& io_index, io::SensorState& state) noexcept;

 private:
  SharedPlant(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double period_s, double wait_s);
  void step() noexcept;  // with the lock held

  std::function<std::unique_ptr<io::Backend>()> make_plant_;
  int parts_;
  std::int64_t half_period_ns_, wait_ns_;
  std::vector<std::uint64_t> next_host_ns_;  ///< per board: its next write's command send time (0: free-running)
  std::vector<std::int64_t> live_ns_;        ///< per board: when its last command came (monotonic)
  bool cycle_open_ = false;
  std::uint64_t cycle_host_ns_ = 0;          ///< the open cycle's host send time
  std::uint64_t stepped_host_ns_ = 0;        ///< the last stepped cycle's (0: none since the restart)
  mutable std::mutex mutex_;
  std::condition_variable stepped_;
  std::unique_ptr<io::Backend> plant_;
  io::Command command_;               ///< every joint's newest command
  io::SensorState state_;             ///< the body's newest sample
  std::uint32_t written_ = 0;         ///< boards that wrote since the last step
  std::uint64_t generation_ = 0;      ///< steps and restarts
  std::uint64_t steps_ = 0, partial_steps_ = 0;
};

}  // namespace peha::mfb
