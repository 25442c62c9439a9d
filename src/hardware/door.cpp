#include "peha/hardware/door.hpp"

#include "peha/mfb/channel_map.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

namespace peha::hardware {
namespace {

/// The host's backend over every board of `link`: one UdpBackend per board (its own socket,
/// session, key and channel map), put together as one io::Backend.
std::unique_ptr<mfb::BoardsBackend> open_boards(const mfb::LinkConfig& link, const std::vector<io::UdpEndpoint>& given,
                                                const HardwareRequest& request) {
  const std::vector<std::string>& joint_names = request.joint_names;
  if (request.one_board && link.boards.size() > 1) {
    throw std::invalid_argument(fmt::format("this experiment runs on one board; the scenario's mfb: section has {} (boards:): run E3 "
                                            "(--experiment postures) on several boards, or give the scenario one channel_map",
                                            link.boards.size()));
  }
  const std::vector<io::UdpEndpoint> at = mfb::board_endpoints(link, given);
  std::vector<mfb::BoardPart> parts;
  for (std::size_t b = 0; b < link.boards.size(); ++b) {
    const mfb::BoardLink& board = link.boards[b];
    // A single-board section read without the io joints drives them all.
    const std::vector<std::string>& names = link.boards.size() == 1 && board.joint_names.empty() ? joint_names : board.joint_names;
    mfb::BoardPart part;
    part.name = board.name;
    for (const std::string& n : names) {
      const auto it = std::find(joint_names.begin(), joint_names.end(), n);
      if (it == joint_names.end()) throw std::invalid_argument(fmt::format("board '{}' carries '{}', which is no io joint", board.name, n));
      part.io_index.push_back(static_cast<int>(it - joint_names.begin()));
    }
    mfb::UdpBackendParams bp;
    bp.board = at[b];
    bp.period_s = request.period_s;
    bp.receive_timeout_s = link.receive_timeout_s;
    bp.joint_names = names;
    bp.key = mfb::load_link_key(board.key_file);
    bp.procedure_key_wanted = request.drives_onto_stops;
    part.backend = std::make_unique<mfb::UdpBackend>(bp, mfb::read_channel_map(config::Document::load_file(board.channel_map), names));
    parts.push_back(std::move(part));
  }
  return std::make_unique<mfb::BoardsBackend>(std::move(parts), joint_names, request.period_s, link.receive_timeout_s);
}

}  // namespace

Hardware open_backend(const BackendUri& uri, const HardwareRequest& request) {
  Hardware hw;
  switch (uri.kind) {
    case BackendKind::kSim:
      if (!request.simulate) throw std::invalid_argument("this run has no simulated plant: give --backend udp://... (a board)");
      hw.backend = request.simulate();
      return hw;
    case BackendKind::kReplay: {
      auto replay = std::make_unique<ReplayBackend>(uri.replay_log, request.joint_names, request.log_prefixes, request.period_s);
      hw.replay = replay.get();
      hw.backend = std::move(replay);
      return hw;
    }
    case BackendKind::kBoards: break;
  }
  if (!request.link) throw std::invalid_argument(fmt::format("--backend {} needs the scenario's mfb: section (channel map, key, watchdogs): see docs/runtime.md", uri.text));
  auto boards = open_boards(*request.link, uri.boards, request);
  hw.boards = boards.get();
  hw.backend = std::move(boards);
  return hw;
}

std::string Hardware::where() const {
  if (replay) return replay->info().name;
  if (!boards) return backend ? backend->info().name : std::string("none");
  std::string text;
  for (std::size_t b = 0; b < boards->board_count(); ++b) {
    const std::string& name = boards->board_name(b);
    text += fmt::format("{}{}udp://{}, session {:08x}", b ? "; " : "", name.empty() ? "" : "board '" + name + "' at ",
                        boards->board(b).board().to_string(), boards->board(b).session_id());
  }
  return text;
}

}  // namespace peha::hardware
