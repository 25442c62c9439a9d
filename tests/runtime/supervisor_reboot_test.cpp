// The supervisor's board-reboot flag: a backend that reports a restart of the board (mfb::UdpBackend:
// a new boot id in its session) faults the run at once, with its own reason, and nothing re-arms the
// outputs until the operator recovers.
#include "peha/io/backend.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/runtime/supervisor.hpp"

#include <gtest/gtest.h>

#include <string>

namespace peha::runtime {
namespace {

/// A board-like backend whose status the test sets; counts the lifecycle calls.
class FakeBoard final : public io::Backend {
 public:
  FakeBoard() { info_.period_s = 1e-3; }
  const io::BackendInfo& info() const override { return info_; }
  void activate() noexcept override {
    ++activations;
    enabled = true;
  }
  void deactivate() noexcept override {
    ++deactivations;
    enabled = false;
    status_.rebooted = false;  // as mfb::UdpBackend: the latch ends with the fault's deactivate()
  }
  void estop() noexcept override { enabled = false; }
  io::BackendStatus status() const noexcept override {
    io::BackendStatus s = status_;
    s.active = enabled;
    s.last_sample_ns = io::monotonic_ns();  // never silent
    return s;
  }
  bool read(io::SensorState&) noexcept override { return true; }
  bool write(const io::Command&) noexcept override { return true; }

  io::BackendStatus status_{};
  bool enabled = false;
  int activations = 0, deactivations = 0;

 private:
  io::BackendInfo info_;
};

TEST(SupervisorReboot, ABoardRestartFaultsTheRunWithItsOwnReasonAndNothingReArms) {
  FakeBoard board;
  Supervisor supervisor(board, SupervisorParams{});
  supervisor.start(0.0);
  io::SensorState state;
  io::Command command;
  for (int k = 1; k <= 10; ++k) supervisor.supervise(k * 1e-3, true, state, command);
  ASSERT_EQ(supervisor.lifecycle().state(), LifecycleState::kActive);
  ASSERT_EQ(board.activations, 1);

  board.status_.rebooted = true;  // the board came back with a new boot id, disarmed, no watchdog trip
  supervisor.supervise(0.011, true, state, command);
  EXPECT_EQ(supervisor.lifecycle().state(), LifecycleState::kFault);
  EXPECT_EQ(supervisor.faults(), 1u);
  EXPECT_FALSE(board.enabled);
  EXPECT_EQ(board.deactivations, 1);
  EXPECT_NE(supervisor.lifecycle().describe_history().find("board reboot"), std::string::npos) << supervisor.lifecycle().describe_history();

  // The new board answers normally: the run stays in fault, outputs disabled, no automatic re-arm.
  for (int k = 12; k <= 3000; ++k) supervisor.supervise(k * 1e-3, true, state, command);
  EXPECT_EQ(supervisor.lifecycle().state(), LifecycleState::kFault);
  EXPECT_EQ(board.activations, 1);
  EXPECT_FALSE(board.enabled);

  // Only the operator's recover arms again.
  supervisor.request_recovery();
  supervisor.supervise(3.001, true, state, command);
  EXPECT_EQ(supervisor.lifecycle().state(), LifecycleState::kRecovering);
  EXPECT_EQ(board.activations, 2);
}

// A backend made of parts (several boards) says which part a fault comes from: the lifecycle's
// reason names it.
TEST(SupervisorReboot, AFaultNamesThePartOfTheBackendItComesFrom) {
  FakeBoard board;
  Supervisor supervisor(board, SupervisorParams{});
  supervisor.start(0.0);
  io::SensorState state;
  io::Command command;
  supervisor.supervise(1e-3, true, state, command);
  board.status_.estop = true;
  board.status_.part = "board 'left'";
  supervisor.supervise(2e-3, true, state, command);
  EXPECT_EQ(supervisor.lifecycle().state(), LifecycleState::kFault);
  EXPECT_NE(supervisor.lifecycle().describe_history().find("-> fault (fault): e-stop on board 'left'"), std::string::npos)
      << supervisor.lifecycle().describe_history();
}

}  // namespace
}  // namespace peha::runtime
