// One backend over several boards (mfb::BoardsBackend), against boards played by the test on
// loopback: each board gets its own joints' commands, the samples come together in io order, and a
// fault or silence of one board is the whole backend's, naming that board.
#include "peha/mfb/boards_backend.hpp"

#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/hardware/door.hpp"
#include "peha/mfb/link_config.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

namespace peha::mfb {
namespace {

/// A board that answers each command (and hello) with a state packet: encoder counts 100 (b + 1) +
/// 10 k for its joint k, mid-range AD codes, the e-stop line inactive, the status bits the test
/// sets, and its nonce of the session (the host's commands carry it after its hello).
struct PlayedBoard {
  io::UdpSocket socket{{0x7F000001u, 0}};
  LinkKey key;
  int index = 0;
  std::uint32_t sequence = 0;
  std::uint8_t status = 0;
  bool silent = false;
  CommandPacket last{};

  /// Answers every command waiting (none if silent).
  int serve() {
    int answered = 0;
    std::array<std::uint8_t, 512> buffer;
    io::UdpEndpoint from;
    for (long n; (n = socket.receive(buffer, from)) >= 0;) {
      CommandPacket c;
      if (decode(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), key, c) != ParseError::kOk) continue;
      last = c;
      if (silent) continue;
      StatePacket s;
      s.session_id = c.session_id;
      s.sequence = ++sequence;
      s.ack_sequence = c.sequence;
      s.echo_host_time_ns = c.host_time_ns;
      s.board_time_ns = sequence * 1'000'000ull;
      s.ad.fill(1000);
      for (int k = 0; k < kEncoderChannels; ++k) s.encoder[static_cast<std::size_t>(k)] = 100 * (index + 1) + 10 * k;
      s.digital_in = 1;  // the e-stop chain closed (active low)
      s.status = status;
      s.boot_id = 7;
      s.board_nonce = 0x5EED0000u + static_cast<std::uint64_t>(index);
      std::array<std::uint8_t, kMaxPacketSize> bytes;
      socket.send_to(from, std::span<const std::uint8_t>(bytes.data(), encode(s, key, bytes)));
      ++answered;
    }
    return answered;
  }
};

struct ThreeBoards : ::testing::Test {
  experiments::ArmScenario scenario =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  std::array<PlayedBoard, 3> boards;
  hardware::Hardware hw;
  BoardsBackend* backend = nullptr;
  io::Command command;
  io::SensorState state;

  ThreeBoards() {
    std::string at;
    for (int b = 0; b < 3; ++b) {
      boards[static_cast<std::size_t>(b)].key = load_link_key(scenario.link->boards[static_cast<std::size_t>(b)].key_file);
      boards[static_cast<std::size_t>(b)].index = b;
      at += (b ? ",udp://" : "udp://") + boards[static_cast<std::size_t>(b)].socket.local().to_string();
    }
    hw = hardware::open_backend(hardware::BackendUri::parse(at), experiments::arm_hardware(scenario, scenario.plant));
    backend = hw.boards;
    command.joint_count = 8;
    cycle();  // the hellos: each board's answer brings its nonce
  }
  /// One cycle: the host sends (and waits its receive timeout), the boards answer, the host reads.
  bool cycle() {
    backend->write(command);
    for (PlayedBoard& b : boards) b.serve();
    const timespec pause{0, 200'000};
    nanosleep(&pause, nullptr);
    return backend->read(state);
  }
};

TEST_F(ThreeBoards, EachBoardGetsItsJointsAndTheSamplesComeTogetherInIoOrder) {
  // io order: R_SAA R_SFE R_EFE R_WFE L_SAA L_SFE L_EFE L_WFE; boards right (R_SFE R_EFE R_WFE),
  // left (L_SFE L_EFE L_WFE), shoulders (R_SAA L_SAA).
  for (int j = 0; j < 8; ++j) command.joints[static_cast<std::size_t>(j)].agonist_pressure_Pa = 1e5 * (j + 1);
  ASSERT_TRUE(cycle());
  ASSERT_EQ(state.joint_count, 8);
  const double rad_per_count = 2.0 * std::numbers::pi / 70000.0;
  const int counts[8] = {300, 100, 110, 120, 310, 200, 210, 220};
  for (int j = 0; j < 8; ++j) EXPECT_NEAR(state.joints[static_cast<std::size_t>(j)].angle_rad, counts[j] * rad_per_count, 1e-12) << j;
  // The valve codes each board got: 0..1 MPa over 0..65535, agonist valves on DA 0, 2, 4 (arms) and 0, 2 (shoulders).
  auto mpa = [](std::uint16_t code) { return code / 65535.0; };
  EXPECT_NEAR(mpa(boards[0].last.da[0]), 0.2, 1e-4);  // R_SFE
  EXPECT_NEAR(mpa(boards[0].last.da[4]), 0.4, 1e-4);  // R_WFE
  EXPECT_NEAR(mpa(boards[1].last.da[2]), 0.7, 1e-4);  // L_EFE
  EXPECT_NEAR(mpa(boards[2].last.da[0]), 0.1, 1e-4);  // R_SAA
  EXPECT_NEAR(mpa(boards[2].last.da[2]), 0.5, 1e-4);  // L_SAA
  EXPECT_EQ(backend->info().joint_names, experiments::arm_joint_names(scenario));
  EXPECT_EQ(backend->stats().commands_sent, 6u);  // a hello, then a command, to each board
  for (const PlayedBoard& b : boards) EXPECT_EQ(b.last.board_nonce, 0x5EED0000u + static_cast<std::uint64_t>(b.index));
}

TEST_F(ThreeBoards, OneBoardsEstopOrWatchdogIsTheBackendsAndNamesTheBoard) {
  ASSERT_TRUE(cycle());
  EXPECT_FALSE(backend->status().estop);
  boards[1].status = kStatusEstop;
  ASSERT_TRUE(cycle());
  io::BackendStatus s = backend->status();
  EXPECT_TRUE(s.estop);
  ASSERT_NE(s.part, nullptr);
  EXPECT_EQ(std::string(s.part), "board 'left'");
  boards[1].status = 0;
  boards[2].status = kStatusWatchdogTripped;
  ASSERT_TRUE(cycle());
  s = backend->status();
  EXPECT_FALSE(s.estop);
  EXPECT_TRUE(s.watchdog_tripped);
  EXPECT_EQ(std::string(s.part), "board 'shoulders'");
}

TEST_F(ThreeBoards, ASilentBoardIsACycleWithoutASampleAndTheOldestBoard) {
  ASSERT_TRUE(cycle());
  boards[0].silent = true;
  const timespec pause{0, 2'000'000};
  nanosleep(&pause, nullptr);
  EXPECT_FALSE(cycle());  // the others answered; without the right arm there is no sample
  const io::BackendStatus s = backend->status();
  ASSERT_NE(s.part, nullptr);
  EXPECT_EQ(std::string(s.part), "board 'right'");  // the host watchdog's fault would name it
  EXPECT_LT(s.last_sample_ns, backend->board(1).last_sample_ns());
  EXPECT_EQ(backend->board(0).stats().replies_missing, 1u);
  EXPECT_EQ(backend->board(1).stats().replies_missing, 0u);
}

}  // namespace
}  // namespace peha::mfb
