#pragma once
/// \file
/// Which hardware a run drives, as one string (`--backend`): the simulated plant, one or several
/// multifunction boards over UDP, or a recorded log replayed into the controller (docs/runtime.md,
/// "One hardware door").
///
///   sim:                              the experiment's simulated plant, in process (the default)
///   udp://A.B.C.D:PORT                one board (a multi-board scenario: board i at PORT + i)
///   udp://A:P,udp://B:Q,...           one address per board of the scenario, in the order of `boards:`
///   replay:<log.csv>                  a recorded run's sensor columns, one row per control cycle

#include "peha/io/udp_socket.hpp"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace peha::hardware {

enum class BackendKind { kSim, kBoards, kReplay };

struct BackendUri {
  BackendKind kind = BackendKind::kSim;
  std::vector<io::UdpEndpoint> boards;  ///< kBoards: every address given, in order
  std::filesystem::path replay_log;     ///< kReplay: the recorded log
  std::string text = "sim:";            ///< as given (for messages and log headers)

  /// Parses `text` ("" is "sim:"). Throws std::invalid_argument naming what was found and the
  /// forms that are accepted.
  static BackendUri parse(std::string_view text);
  /// True for a backend that runs inside this process at the speed it computes (sim:, replay:);
  /// false for one in real time on hardware (udp://).
  bool in_process() const noexcept { return kind != BackendKind::kBoards; }
  /// "the simulated plant", "the board at udp://...", "the replay of <log>" (for messages).
  std::string describe() const;
};

}  // namespace peha::hardware
