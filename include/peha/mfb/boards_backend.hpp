#pragma once
/// \file
/// One io::Backend over several multifunction boards: a body whose joints do not fit one board
/// (the upper body: one board per arm) runs on one board per channel map (docs/channel-maps.md),
/// each with its own mfb::UdpBackend - its own UDP socket, session, key, sequence numbers and the
/// board's own watchdog. The joints are split by the maps: io joint `j` is joint `k` of board `b`.
///
/// One control cycle: write() sends every board its part of the command, then waits (one deadline,
/// `receive_timeout_s` after the first send) for every board's reply; read() puts the boards'
/// samples together. A cycle without a new sample from any board is a cycle without a sample
/// (read() returns false and the loop holds its command), and a fault of any board - silence,
/// e-stop, its watchdog, a reboot - is the whole backend's: status() says which board
/// (`BackendStatus::part`), so the run's lifecycle names it. With one board it behaves as that
/// board's UdpBackend. read()/write()/status() are noexcept and allocation-free.

#include "peha/io/backend.hpp"
#include "peha/mfb/udp_backend.hpp"

#include <memory>
#include <string>
#include <vector>

namespace peha::mfb {

/// One board of a BoardsBackend: its name (for messages), its backend and where its joints sit in
/// the io order (`io_index[k]` = io joint of the board's joint k).
struct BoardPart {
  std::string name;
  std::unique_ptr<UdpBackend> backend;
  std::vector<int> io_index;
};

class BoardsBackend final : public io::Backend {
 public:
  /// `joint_names` are the io joints; every one must be on exactly one board (std::invalid_argument
  /// otherwise: a programming error, read_link_config checks the files).
  BoardsBackend(std::vector<BoardPart> boards, const std::vector<std::string>& joint_names, double period_s,
                double receive_timeout_s);

  const io::BackendInfo& info() const override { return info_; }
  /// Connects every board in turn (each one's session handshake). Throws std::runtime_error naming
  /// the board that did not answer.
  void configure() override;
  void activate() noexcept override;
  void deactivate() noexcept override;
  void estop() noexcept override;
  /// Every board active -> active; any board's e-stop, watchdog trip or reboot -> the backend's,
  /// `part` naming the first such board; the oldest board's last sample (so one silent board
  /// trips the host watchdog, `part` naming it when nothing else is wrong); the longest round trip
  /// of the newest samples.
  io::BackendStatus status() const noexcept override;
  /// Every board's newest sample in io order; false if any board has none (each board counts its own).
  bool read(io::SensorState& state) noexcept override;
  /// Sends each board its joints' commands, then waits for all replies (one deadline).
  bool write(const io::Command& command) noexcept override;

  std::size_t board_count() const noexcept { return boards_.size(); }
  const std::string& board_name(std::size_t b) const noexcept { return boards_[b].name; }
  const UdpBackend& board(std::size_t b) const noexcept { return *boards_[b].backend; }
  UdpBackend& board(std::size_t b) noexcept { return *boards_[b].backend; }
  /// The links' counters summed over the boards (the round trip's max over them).
  UdpLinkStats stats() const noexcept;
  /// Receives each board's round trips, one per cycle that brought a new one (read() reports them);
  /// the statistics live in a higher layer (experiments: runtime::Histogram per board). Null: none.
  class RttSink {
   public:
    virtual ~RttSink() = default;
    virtual void add(std::size_t board, double rtt_s) noexcept = 0;
  };
  void set_rtt_sink(RttSink* sink) noexcept { rtt_sink_ = sink; }

 private:
  void record_rtt() noexcept;

  std::vector<BoardPart> boards_;
  std::vector<std::string> labels_;        ///< "board 'name'" per board (BackendStatus::part points here)
  io::BackendInfo info_;
  double receive_timeout_s_;
  std::vector<io::SensorState> samples_;   ///< per board, preallocated
  std::vector<io::Command> commands_;      ///< per board, preallocated
  RttSink* rtt_sink_ = nullptr;
  std::vector<std::uint64_t> rtt_seen_;     ///< per board: its round trips counted when last recorded
};

}  // namespace peha::mfb
