#pragma once
/// \file
/// One simulated body behind several emulated boards (`peha mfb-emulator` for a scenario on several
/// boards, docs/channel-maps.md): each board's BoardEmulator runs in its own thread with its own
/// socket, key, session and watchdog, and sees the plant through a view of its joints
/// (SharedPlant::view). The plant stays one physical simulation of the whole body (one MuJoCo
/// model): it steps once every board has applied its outputs for the period - the host sends all
/// boards their commands in one cycle, so each step takes every board's command of that cycle, and
/// every board then replies with the sample after that step, as the in-process run sees it.
///
/// A board that does not come within `wait_s` (its host silent, its thread descheduled) does not
/// hold the body: the step goes on with that board's last outputs. A new session on any board
/// (the host connecting) restarts the whole body in its initial state.

#include "peha/io/backend.hpp"

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace peha::mfb {

class SharedPlant : public std::enable_shared_from_this<SharedPlant> {
 public:
  /// `make_plant` builds the whole body in its initial state; `parts` boards share it; a step
  /// waits at most `wait_s` for the boards that have not written yet.
  static std::shared_ptr<SharedPlant> create(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double wait_s);

  /// What board `part` drives and senses: io joints `io_index` (its joint k = io joint io_index[k]).
  /// Restarts the body (a board's new session): pass it as the board's `make_plant`.
  std::unique_ptr<io::Backend> view(int part, const std::vector<int>& io_index);

  /// Steps the body taken (for the emulator's report).
  std::uint64_t steps() const;
  /// Steps taken without every board's outputs (a board came later than wait_s).
  std::uint64_t partial_steps() const;

  // Called by the views (under the lock).
  void write(int part, const std::vector<int>& io_index, const io::Command& command) noexcept;
  void read(const std::vector<int>& io_index, io::SensorState& state) noexcept;

 private:
  SharedPlant(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double wait_s);
  void step() noexcept;  // with the lock held

  std::function<std::unique_ptr<io::Backend>()> make_plant_;
  std::uint32_t all_;                 ///< bit per board
  double wait_s_;
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
