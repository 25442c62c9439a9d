#include "peha/mfb/link_config.hpp"

namespace peha::mfb {

LinkConfig read_link_config(config::Map map) {
  LinkConfig l;
  l.channel_map = map.path_value("channel_map");
  l.board_watchdog_s = map.number("board_watchdog_ms", {2.0, 10000.0}) * 1e-3;
  l.host_watchdog_s = map.number("host_watchdog_ms", {2.0, 10000.0}) * 1e-3;
  l.receive_timeout_s = map.number("receive_timeout_ms", {0.05, 100.0}) * 1e-3;
  l.vent_s = map.number("vent_s", {0.0, 60.0});
  l.recovery_ramp_s = map.number("recovery_ramp_s", {0.0, 60.0});
  map.finish();
  return l;
}

std::unique_ptr<UdpBackend> make_board_backend(const LinkConfig& link, const io::UdpEndpoint& board, double period_s,
                                               const std::vector<std::string>& joint_names) {
  UdpBackendParams bp;
  bp.board = board;
  bp.period_s = period_s;
  bp.receive_timeout_s = link.receive_timeout_s;
  bp.joint_names = joint_names;
  return std::make_unique<UdpBackend>(bp, read_channel_map(config::Document::load_file(link.channel_map), joint_names));
}

}  // namespace peha::mfb
