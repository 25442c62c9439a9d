#include "peha/hardware/backend_uri.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace peha::hardware {
namespace {

constexpr const char* kForms = "sim:, udp://A.B.C.D:PORT (several boards: udp://A:P,udp://B:Q), replay:<log.csv>";

}  // namespace

BackendUri BackendUri::parse(std::string_view text) {
  BackendUri uri;
  uri.text = text.empty() ? "sim:" : std::string(text);
  if (text.empty() || text == "sim:" || text == "sim") return uri;
  if (text.starts_with("replay:")) {
    uri.kind = BackendKind::kReplay;
    uri.replay_log = std::string(text.substr(7));
    if (uri.replay_log.empty()) throw std::invalid_argument(fmt::format("--backend replay: names no log; expected replay:<log.csv>"));
    return uri;
  }
  if (text.starts_with("udp://")) {
    uri.kind = BackendKind::kBoards;
    std::string_view rest = text;
    for (;;) {
      const auto comma = rest.find(',');
      uri.boards.push_back(io::parse_udp_endpoint(std::string(rest.substr(0, comma))));  // throws, naming the address
      if (comma == std::string_view::npos) break;
      rest = rest.substr(comma + 1);
    }
    return uri;
  }
  throw std::invalid_argument(fmt::format("--backend '{}': expected one of {}", text, kForms));
}

std::string BackendUri::describe() const {
  switch (kind) {
    case BackendKind::kSim: return "the simulated plant";
    case BackendKind::kReplay: return "the replay of " + replay_log.string();
    case BackendKind::kBoards: break;
  }
  return boards.size() == 1 ? "the board at udp://" + boards.front().to_string() : "the boards at " + text;
}

}  // namespace peha::hardware
