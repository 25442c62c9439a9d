// `peha check-config`: the scenario through its experiment's reader (found in the registry), then
// the board's channel map for the backend's joints.
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"

#include <fmt/format.h>

namespace peha::app {

int check_config(const std::filesystem::path& config) {
  try {
    const config::Document doc = config::Document::load_file(config);
    const ScenarioCheck checked = find_experiment(doc).check(config, doc);
    if (const auto& link = checked.link) {  // the board's channel map must load for the backend's joints
      const mfb::ChannelMap map = mfb::read_channel_map(config::Document::load_file(link->channel_map), checked.joints);
      fmt::print("  mfb: channel map {} ({} joints), watchdogs board {} ms / host {} ms\n", link->channel_map.string(), map.joint_count(),
                 link->board_watchdog_s * 1e3, link->host_watchdog_s * 1e3);
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  }
}

}  // namespace peha::app
