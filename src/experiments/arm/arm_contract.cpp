#include "peha/experiments/arm/arm_contract.hpp"

#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "peha/experiments/e3_postures/postures_report.hpp"
#include "peha/experiments/e4_goniometer/goniometer_report.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth_report.hpp"
#include "peha/sim/arm_plant.hpp"

#include <fmt/format.h>

namespace peha::experiments {
namespace {

ScenarioCheck check_arm(const std::filesystem::path& config, const config::Document& doc) {
  const ArmScenario s = read_arm_scenario(doc);
  fmt::print("{}\n  experiment arm: {}\n  {} actuated joints, {} postures (E3), {} goniometer movement(s) (E4), "
             "{} bandwidth frequencies (E6), control at {} Hz\n",
             config.string(), s.description, s.controller.joints.size(), s.postures.size(), s.goniometer.movements.size(),
             s.bandwidth.frequencies_Hz.size(), 1.0 / s.period_s);
  std::vector<mfb::JointEnvelope> envelopes;
  for (std::size_t i = 0; i < s.controller.joints.size(); ++i) {
    envelopes.push_back(joint_envelope(arm_joint_names(s)[i], s.controller.joints[i].actuator, s.limits.joints[i]));
  }
  return {arm_joint_names(s), s.link, s.lifecycle, envelopes};
}

/// Why an arm scenario's faults: list does not go with `what` (in process: E3 and E4 take it).
std::string faults_not_for(const config::Document& doc, const char* what) {
  return fmt::format("{}: its faults: list is injected in E3 and E4 (--experiment postures, goniometer) only, not in {}: remove it for "
                     "this run", doc.name(), what);
}

/// The emulator's cases other than E3's refuse the scenario's faults: list (with a message).
bool refuse_arm_faults(const config::Document& doc, const ArmScenario& scenario, const char* what) {
  if (scenario.faults.empty()) return false;
  fmt::print(stderr, "config error: {}: its faults: list is injected by the emulator in E3's plant only (--case postures), not in {}: "
                     "remove it for this run (in process, E4 takes it)\n", doc.name(), what);
  return true;
}

std::optional<BoardPlant> arm_board(const config::Document& doc, const EmulatorCase& options) {
  auto scenario = std::make_shared<ArmScenario>(read_arm_scenario(doc));
  if (options.seed) scenario->plant.seed = scenario->seed = *options.seed;
  if (!has_link(doc, scenario->link)) return std::nullopt;
  if (const std::string outage = emulator_outage_error(scenario->faults); !outage.empty()) {
    fmt::print(stderr, "config error: {}: {}\n", doc.name(), outage);
    return std::nullopt;
  }
  BoardPlant board{scenario->period_s, *scenario->link, {}, {}, {}, {}};
  for (const mfb::BoardLink& b : scenario->link->boards) {  // each board's map with its joints (all of them on one board)
    board.maps.push_back(mfb::read_channel_map(config::Document::load_file(b.channel_map), b.joint_names));
  }
  if (options.case_name == "free") {  // the arm alone, nobody holding it: a user's own controller (peha::api::Exoskeleton)
    const sim::ArmPlantParams plant = scenario->plant;
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints, nobody holding the arm (a user's own controller)", arm_joint_names(*scenario).size());
    return board;
  }
  if (options.case_name == "identification") {  // peha identify-gravity's procedure: the operator holds the start posture, then the rig sweeps
    if (!scenario->identification) {
      fmt::print(stderr, "config error: {}: no identification: section to serve --case identification\n", doc.name());
      return std::nullopt;
    }
    const sim::ArmPlantParams plant = identification_plant_params(identification_scenario(*scenario), scenario->plant);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints for peha identify-gravity ({} postures)", arm_joint_names(*scenario).size(),
                             scenario->identification->postures.size());
    return board;
  }
  if (options.case_name.empty() || options.case_name == "postures") {
    const sim::ArmPlantParams plant = postures_plant_params(*scenario);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints with the operator's E3 script ({} postures)", arm_joint_names(*scenario).size(),
                             scenario->postures.size());
    return board;
  }
  // E4: the arm where the person starts, and the person's goniometer on its AD channel.
  const auto& g = scenario->goniometer;
  for (std::size_t i = 0; i < g.movements.size(); ++i) {
    if (options.case_name != "goniometer_" + g.movements[i].name) continue;
    if (refuse_arm_faults(doc, *scenario, "E4 (goniometer)")) return std::nullopt;
    if (board.maps.size() > 1) {
      fmt::print(stderr, "error: {}: E4 (goniometer) runs on one board; this scenario has {} (mfb: boards:)\n", doc.name(), board.maps.size());
      return std::nullopt;
    }
    for (const int j : g.joints) {
      if (!board.maps[0].has_goniometer(j)) {
        fmt::print(stderr, "config error: {}: no {}.goniometer channel to put the person's joint on\n", scenario->link->channel_map.string(),
                   arm_joint_names(*scenario)[static_cast<std::size_t>(j)]);
        return std::nullopt;
      }
    }
    const std::vector<GoniometerTrace> traces = synthesize_goniometers(g, g.movements[i], scenario->seed + i);
    const sim::ArmPlantParams plant = goniometer_plant_params(*scenario, traces);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    std::vector<mfb::AnalogChannel> channels;  // each driven joint's goniometer channel
    for (const int j : g.joints) channels.push_back(board.maps[0].joint(j).goniometer);
    board.input_hook = [scenario, traces, channels](double t_s, mfb::BoardInputs& in) {
      bool clamped = false;
      for (std::size_t k = 0; k < traces.size(); ++k) {
        in.ad[static_cast<std::size_t>(channels[k].channel)] = channels[k].to_code(goniometer_reading(*scenario, traces[k], t_s), clamped);
      }
    };
    board.what = fmt::format("arm, E4: a person's movement '{}' on the goniometer channel of each driven joint", g.movements[i].name);
    return board;
  }
  std::string cases = "postures, identification, free";
  for (const auto& m : g.movements) cases += ", goniometer_" + m.name;
  fmt::print(stderr, "error: the arm's board serves --case {}; found '{}'\n", cases, options.case_name);
  return std::nullopt;
}

}  // namespace

ArmScenario arm_scenario_for_run(const config::Document& doc, const RunRequest& request, const char* what, bool takes_faults) {
  ArmScenario scenario = read_arm_scenario(doc);
  if (!takes_faults && !scenario.faults.empty()) {
    throw RequestError(faults_not_for(doc, what));
  }
  if (request.seed) scenario.plant.seed = scenario.seed = *request.seed;
  if (request.force_trim_rate_1ps) scenario.controller.allocation.force_trim_rate_1ps = *request.force_trim_rate_1ps;
  if (!request.gravity_identification.empty()) use_gravity_identification(scenario, request.gravity_identification);
  return scenario;
}

Experiment arm_experiment() {
  Takes e3;
  e3.force_trim = e3.gravity_identification = e3.faults = e3.boards = e3.replay = true;
  Takes e4;
  e4.cases = e4.goniometer_csv = e4.force_trim = e4.gravity_identification = e4.faults = e4.boards = e4.replay = true;
  Takes e6;
  e6.force_trim = e6.gravity_identification = true;
  e6.why_not_hardware = "E6 runs in-process only: it needs the joint's true delivered torque, which no board sensor measures";
  return {"arm", "arm",
          "an arm or the upper body (configs/right_arm.yaml, configs/upper_body.yaml): E3 postures, E4 goniometer, E6 bandwidth (--experiment)",
          {{"postures", "E3 postures", e3, make_postures_run},
           {"goniometer", "E4 goniometer", e4, make_goniometer_run},
           {"bandwidth", "E6 bandwidth", e6, make_bandwidth_run}},
          check_arm, arm_board};
}

}  // namespace peha::experiments
