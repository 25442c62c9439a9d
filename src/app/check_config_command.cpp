// `peha check-config`: the scenario through its experiment's reader (found in the registry), then
// the board's channel map for the backend's joints and the link's key file.
#include "peha/app/commands.hpp"
#include "peha/app/registry.hpp"
#include "peha/experiments/false_alarms/false_alarms.hpp"
#include "peha/experiments/robustness/robustness.hpp"
#include "peha/mfb/board_core.hpp"
#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace peha::app {
namespace {

/// The board's limits against the scenario, one row each: true if every row agrees.
bool print_board_limit_checks(const std::vector<mfb::BoardLimitCheck>& rows) {
  fmt::print("    {:<8} {:<24} {:>9} {:>9}  {:<8} {}\n", "joint", "board_limits field", "board", "scenario", "verdict", "rule");
  bool all = true;
  for (const mfb::BoardLimitCheck& r : rows) {
    fmt::print("    {:<8} {:<24} {:>9.4g} {:>9.4g}  {:<8} {}\n", r.joint, r.field, r.board, r.scenario, r.agrees ? "agrees" : "DISAGREES", r.rule);
    all = all && r.agrees;
  }
  return all;
}

}  // namespace

int check_config(const std::filesystem::path& config) {
  try {
    const config::Document doc = config::Document::load_file(config);
    if (config::Map root = doc.root(); root.has("experiment") && root.string("experiment") == "robustness") {
      // A robustness matrix (peha robustness): its file, and the scenarios it names.
      const experiments::RobustnessConfig matrix = experiments::read_robustness(doc);
      if (!matrix.e1_config.empty()) experiments::read_e1(config::Document::load_file(matrix.e1_config));
      if (!matrix.arm_config.empty()) experiments::read_arm_scenario(config::Document::load_file(matrix.arm_config));
      experiments::read_robustness_scenarios(matrix);  // and E4's persons against the arm's range
      fmt::print("{}: robustness matrix, {} mode(s) x {} variant(s) x {} seed(s); scenarios {} and {} read\n", doc.name(),
                 matrix.modes.size(), matrix.variants.size(), matrix.seeds.size(), matrix.e1_config.string(), matrix.arm_config.string());
      return 0;
    }
    if (config::Map root = doc.root(); root.has("experiment") && root.string("experiment") == "false_alarms") {
      // The false-alarm statistics (peha false-alarms): its file, and every case's scenario.
      const experiments::FalseAlarmConfig fa = experiments::read_false_alarms(doc);
      for (const experiments::FalseAlarmCase& c : fa.cases) {
        if (c.run == experiments::FalseAlarmRun::kE1) {
          experiments::read_e1(config::Document::load_file(c.scenario));
        } else {
          experiments::read_arm_scenario(config::Document::load_file(c.scenario));
        }
      }
      fmt::print("{}: false-alarm statistics, {} case(s) x {} noise scale(s) x {} seed(s), {} variant(s) x {} seed(s); scenarios read\n",
                 doc.name(), fa.cases.size(), fa.noise_scales.size(), fa.seeds, fa.variants.size(), fa.variant_seeds);
      return 0;
    }
    const ScenarioCheck checked = find_experiment(doc).check(config, doc);
    bool limits_agree = true;
    if (const auto& link = checked.link) {  // each board's channel map must load for its joints
      for (const mfb::BoardLink& b : link->boards) {
        const std::vector<std::string>& joints = link->boards.size() == 1 ? checked.joints : b.joint_names;
        const mfb::ChannelMap map = mfb::read_channel_map(config::Document::load_file(b.channel_map), joints);
        mfb::load_link_key(b.key_file);  // the pre-shared key both ends authenticate with: present, private, 32 bytes
        fmt::print("  mfb{}: channel map {} ({} joints: {}), watchdogs board {} ms / host {} ms, key file {} read\n",
                   b.name.empty() ? "" : " board '" + b.name + "'", b.channel_map.string(), map.joint_count(), fmt::join(joints, " "),
                   link->board_watchdog_s * 1e3, checked.lifecycle.host_watchdog_s * 1e3, b.key_file.string());
        // The board enforces the scenario's own hard numbers, never looser ones (docs/commissioning.md).
        if (!print_board_limit_checks(mfb::board_limit_checks(map, checked.envelopes))) limits_agree = false;
      }
    }
    if (!limits_agree) {
      fmt::print(stderr, "config error: {}: the board_limits of its channel map disagree with the scenario (table above)\n", config.string());
      return 2;
    }
    fmt::print("{}: OK\n", config.string());  // only once everything it names has loaded
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  }
}

}  // namespace peha::app
