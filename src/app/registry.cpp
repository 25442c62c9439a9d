#include "peha/app/registry.hpp"

#include "peha/experiments/arm_identification/arm_identification.hpp"
#include "peha/experiments/creep/creep.hpp"
#include "peha/experiments/e1_gravity/e1_report.hpp"
#include "peha/experiments/e3_postures/postures_report.hpp"
#include "peha/experiments/e4_goniometer/goniometer_report.hpp"
#include "peha/experiments/e5_max_force/max_force_report.hpp"
#include "peha/experiments/e6_bandwidth/bandwidth_report.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/mujoco_model.hpp"
#include "peha/sim/one_dof_rig.hpp"
#include "peha/sim/arm_plant.hpp"

#include <fmt/format.h>

namespace peha::app {
namespace {

// --- gravity_compensation_1dof: E1 on the one-DOF rig ---

ScenarioCheck check_e1(const std::filesystem::path& config, const config::Document& doc) {
  const experiments::E1Scenario s = experiments::read_e1(doc);
  sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}: OK\n  experiment gravity_compensation_1dof: {}\n  {} case(s), {} s at {} Hz, {} finger push(es), "
             "plant model {}\n",
             config.string(), s.description, s.cases.size(), s.duration_s, 1.0 / s.period_s, s.plant.finger.pushes.size(),
             s.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.link, s.lifecycle};
}

/// The emulator's plant: the one the hardware door simulates for `request` (exactly what a sim: run
/// of the same case drives), behind the scenario's one board.
BoardPlant board_for(const mfb::LinkConfig& link, double period_s, const hardware::HardwareRequest& request, std::string what) {
  return BoardPlant{period_s, link, {mfb::read_channel_map(config::Document::load_file(link.channel_map), request.joint_names)},
                    request.simulate, {}, std::move(what)};
}

/// The index of the case --case names among `names` (the only one when none is given); nullopt after
/// a message listing the cases (`meaning`: what a case is, for the message).
std::optional<std::size_t> chosen_case(const config::Document& doc, const std::vector<std::string>& names, const std::string& given,
                                       const char* meaning, const std::string& also) {
  std::string cases;
  for (const auto& n : names) cases += (cases.empty() ? "" : ", ") + n;
  if (!also.empty()) cases += ", " + also;
  if (given.empty() && names.size() > 1) {
    fmt::print(stderr, "error: {} has {} cases: give --case NAME ({}; the host's peha run --backend needs the same --case): {}\n", doc.name(),
               names.size(), meaning, cases);
    return std::nullopt;
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (given.empty() || names[i] == given) return i;
  }
  fmt::print(stderr, "error: no case named '{}' in {} (it has {})\n", given, doc.name(), cases);
  return std::nullopt;
}

/// The scenario's mfb: section, or nullopt after a message.
bool has_link(const config::Document& doc, const std::optional<mfb::LinkConfig>& link) {
  if (!link) fmt::print(stderr, "config error: {}: no mfb: section (channel map, watchdogs): see docs/runtime.md\n", doc.name());
  return link.has_value();
}

std::optional<BoardPlant> e1_board(const config::Document& doc, const EmulatorOptions& options) {
  experiments::E1Scenario scenario = experiments::read_e1(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  if (!has_link(doc, scenario.link)) return std::nullopt;
  // The calibration recording: the rig with the excitation's payload, pinned where the operator pins it.
  for (int m = 0; m < 2; ++m) {
    const char* muscle = m == 0 ? "agonist" : "antagonist";
    if (options.case_name != std::string("calibration_") + muscle) continue;
    if (!scenario.excitation[m]) {
      fmt::print(stderr, "config error: {}: no calibration.{} section to serve --case {}\n", doc.name(), muscle, options.case_name);
      return std::nullopt;
    }
    return board_for(*scenario.link, scenario.period_s, experiments::e1_recording_hardware(scenario, scenario.plant, m),
                     fmt::format("one-DOF rig for peha record-calibration --muscle {} ({} kg, pinned for the tare and the clamped segments)",
                                 muscle, scenario.excitation[m]->payload_kg));
  }
  std::vector<std::string> names;
  for (const auto& c : scenario.cases) names.push_back(c.name);
  const std::optional<std::size_t> i =
      chosen_case(doc, names, options.case_name, "the payload the simulated rig carries", "calibration_agonist, calibration_antagonist");
  if (!i) return std::nullopt;
  const experiments::E1Case& c = scenario.cases[*i];
  return board_for(*scenario.link, scenario.period_s, experiments::e1_hardware(scenario, c),
                   fmt::format("one-DOF rig, case {} ({} kg)", c.name, c.payload_kg));
}

// --- wire_creep: the creep estimator's long E1-like run on the one-DOF rig ---

ScenarioCheck check_creep(const std::filesystem::path& config, const config::Document& doc) {
  const experiments::CreepScenario s = experiments::read_creep(doc);
  sim::load_mjcf(s.e1.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}: OK\n  experiment wire_creep: {}\n  {} s at {} Hz, {} finger push(es), {} plant variant(s) x {} trim rate(s) x "
             "estimator off/on, plant model {}\n",
             config.string(), s.e1.description, s.e1.duration_s, 1.0 / s.e1.period_s, s.e1.plant.finger.pushes.size(),
             s.creep.variants.size(), s.creep.force_trim_rates_1ps.size(), s.e1.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.e1.link, s.e1.lifecycle};
}

std::optional<BoardPlant> creep_board(const config::Document& doc, const EmulatorOptions&) {
  fmt::print(stderr, "error: {}: the wire-creep experiment runs in-process only (it judges the estimate against the plant's "
                     "true creep); serve its E1 scenario instead\n", doc.name());
  return std::nullopt;
}

// --- max_force_ramp: E5 on the clamped one-DOF rig ---

ScenarioCheck check_e5(const std::filesystem::path& config, const config::Document& doc) {
  const experiments::E5Scenario s = experiments::read_e5(doc);
  sim::load_mjcf(s.plant.model_file);  // the model file must exist and load, too
  fmt::print("{}: OK\n  experiment max_force_ramp: {}\n  {} case(s), {} ramped at {} MPa/s, {} s at {} Hz, plant model {}\n",
             config.string(), s.description, s.cases.size(), s.ramp.muscle == 0 ? "agonist" : "antagonist", s.ramp.rate_Pa_per_s * 1e-6,
             s.duration_s, 1.0 / s.period_s, s.plant.model_file.string());
  return {sim::one_dof_rig_joint_names(), s.link, s.lifecycle};
}

std::optional<BoardPlant> e5_board(const config::Document& doc, const EmulatorOptions& options) {
  experiments::E5Scenario scenario = experiments::read_e5(doc);
  if (options.seed) scenario.plant.seed = scenario.seed = *options.seed;
  if (!has_link(doc, scenario.link)) return std::nullopt;
  std::vector<std::string> names;
  for (const auto& c : scenario.cases) names.push_back(c.name);
  const std::optional<std::size_t> i = chosen_case(doc, names, options.case_name, "the clamp's angle", "");
  if (!i) return std::nullopt;
  const experiments::E5Case& c = scenario.cases[*i];
  return board_for(*scenario.link, scenario.period_s, experiments::e5_hardware(scenario, c),
                   fmt::format("one-DOF rig clamped, case {} ({} deg)", c.name, models::rad_to_deg(c.locked_angle_rad)));
}

// --- arm: E3 postures, E4 goniometer, E6 bandwidth ---

ScenarioCheck check_arm(const std::filesystem::path& config, const config::Document& doc) {
  const experiments::ArmScenario s = experiments::read_arm_scenario(doc);
  fmt::print("{}: OK\n  experiment arm: {}\n  {} actuated joints, {} postures (E3), {} goniometer movement(s) (E4), "
             "{} bandwidth frequencies (E6), control at {} Hz\n",
             config.string(), s.description, s.controller.joints.size(), s.postures.size(), s.goniometer.movements.size(),
             s.bandwidth.frequencies_Hz.size(), 1.0 / s.period_s);
  return {experiments::arm_joint_names(s), s.link, s.lifecycle};
}

using ArmRun = int (*)(const config::Document&, const experiments::ArmScenario&, const experiments::RunRequest&,
                       std::optional<experiments::HardwareRunOptions>);

/// An arm scenario's `faults:` list is E3's: the other experiments refuse it (with a message).
bool refuse_arm_faults(const config::Document& doc, const experiments::ArmScenario& scenario, const char* what) {
  if (scenario.faults.empty()) return false;
  fmt::print(stderr, "config error: {}: its faults: list is injected in E3 (--experiment postures) only, not in {}: "
                     "remove it for this run\n", doc.name(), what);
  return true;
}

/// An arm scenario with the request's seed and force trim; over the board, its mfb:
/// section and the real-time options are checked before `run` writes anything. `what` names the
/// experiment; only E3 (`takes_faults`) takes the scenario's faults: list.
int run_arm(const config::Document& doc, const experiments::RunRequest& request, ArmRun run, const char* what, bool takes_faults) {
  experiments::ArmScenario scenario = experiments::read_arm_scenario(doc);
  if (!takes_faults && refuse_arm_faults(doc, scenario, what)) return 2;
  if (request.seed) scenario.plant.seed = scenario.seed = *request.seed;
  if (request.force_trim_rate_1ps) scenario.controller.allocation.force_trim_rate_1ps = *request.force_trim_rate_1ps;
  if (!request.gravity_identification.empty()) experiments::use_gravity_identification(scenario, request.gravity_identification);
  hardware::BackendUri uri;
  std::optional<experiments::HardwareRunOptions> realtime;
  if (!experiments::check_hardware(doc.name(), scenario.link ? &*scenario.link : nullptr, 1, request, uri, realtime)) return 2;
  return run(doc, scenario, request, std::move(realtime));
}

int run_bandwidth(const config::Document& doc, const experiments::ArmScenario& scenario, const experiments::RunRequest& request,
                  std::optional<experiments::HardwareRunOptions>) {
  return experiments::run_bandwidth_experiment(doc, scenario, request);
}

std::optional<BoardPlant> arm_board(const config::Document& doc, const EmulatorOptions& options) {
  auto scenario = std::make_shared<experiments::ArmScenario>(experiments::read_arm_scenario(doc));
  if (options.seed) scenario->plant.seed = scenario->seed = *options.seed;
  if (!has_link(doc, scenario->link)) return std::nullopt;
  BoardPlant board{scenario->period_s, *scenario->link, {}, {}, {}, {}};
  for (const mfb::BoardLink& b : scenario->link->boards) {  // each board's map with its joints (all of them on one board)
    board.maps.push_back(mfb::read_channel_map(config::Document::load_file(b.channel_map), b.joint_names));
  }
  if (options.case_name == "free") {  // the arm alone, nobody holding it: a user's own controller (peha::api::Exoskeleton)
    const sim::ArmPlantParams plant = scenario->plant;
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints, nobody holding the arm (a user's own controller)", experiments::arm_joint_names(*scenario).size());
    return board;
  }
  if (options.case_name == "identification") {  // peha identify-gravity's procedure: the operator holds the start posture, then the rig sweeps
    if (!scenario->identification) {
      fmt::print(stderr, "config error: {}: no identification: section to serve --case identification\n", doc.name());
      return std::nullopt;
    }
    const sim::ArmPlantParams plant = experiments::identification_plant_params(experiments::identification_scenario(*scenario), scenario->plant);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints for peha identify-gravity ({} postures)", experiments::arm_joint_names(*scenario).size(),
                             scenario->identification->postures.size());
    return board;
  }
  if (options.case_name.empty() || options.case_name == "postures") {
    const sim::ArmPlantParams plant = experiments::postures_plant_params(*scenario);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    board.what = fmt::format("{} joints with the operator's E3 script ({} postures)", experiments::arm_joint_names(*scenario).size(),
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
                   experiments::arm_joint_names(*scenario)[static_cast<std::size_t>(j)]);
        return std::nullopt;
      }
    }
    const std::vector<experiments::GoniometerTrace> traces = experiments::synthesize_goniometers(g, g.movements[i], scenario->seed + i);
    const sim::ArmPlantParams plant = experiments::goniometer_plant_params(*scenario, traces);
    board.make_plant = [plant] { return std::make_unique<sim::ArmBackend>(plant); };
    std::vector<mfb::AnalogChannel> channels;  // each driven joint's goniometer channel
    for (const int j : g.joints) channels.push_back(board.maps[0].joint(j).goniometer);
    board.input_hook = [scenario, traces, channels](double t_s, mfb::BoardInputs& in) {
      bool clamped = false;
      for (std::size_t k = 0; k < traces.size(); ++k) {
        in.ad[static_cast<std::size_t>(channels[k].channel)] = channels[k].to_code(experiments::goniometer_reading(*scenario, traces[k], t_s), clamped);
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

const Refusal kNoArmCalibration[] = {
    {"--agonist-calibration", "an arm scenario's muscles have no calibration input yet (calibration files are for the one-DOF rig's E1)"},
    {"--antagonist-calibration", "an arm scenario's muscles have no calibration input yet (calibration files are for the one-DOF rig's E1)"},
};
const std::string kIdentificationElsewhere =
    "gravity identification files are for an arm scenario (peha identify-gravity)";
const std::string kCsvElsewhere = "a recorded goniometer drives an arm scenario's E4 only (--experiment goniometer)";
const std::string kFaultsElsewhere = "plant faults are injected in E1 and an arm scenario's E3 (--experiment postures)";

std::vector<Refusal> arm_refusals(std::vector<Refusal> more) {
  more.insert(more.begin(), std::begin(kNoArmCalibration), std::end(kNoArmCalibration));
  return more;
}

std::vector<ExperimentEntry> make_registry() {
  std::vector<ExperimentEntry> r;
  r.push_back({"gravity_compensation_1dof", "one-DOF rig",
               "E1: gravity compensation of the one-DOF PEHA rig with each payload (configs/e1_one_dof.yaml)",
               {{"", "E1 gravity compensation",
                 {"--case", "--agonist-calibration", "--antagonist-calibration", "--force-trim-rate", "--backend", "--fault"},
                 {{"--goniometer-csv", "a recorded goniometer drives an arm scenario's E4 (--experiment goniometer)"},
                  {"--gravity-identification", kIdentificationElsewhere}},
                 {{"--fault", "over the board the plant is the emulator's: give the faults in the scenario's faults: list"}},
                 experiments::run_e1_experiment}},
               check_e1, e1_board});
  r.push_back({"wire_creep", "one-DOF rig",
               "wire creep and slack: the creep estimator off and on over a long E1-like run (configs/e1_creep.yaml)",
               {{"", "wire creep estimator",
                 {"--case", "--force-trim-rate"},
                 {{"--backend", "the creep experiment judges the estimate against the plant's true creep: in-process only"},
                  {"--agonist-calibration", "the creep experiment runs the scenario's own muscle models"},
                  {"--antagonist-calibration", "the creep experiment runs the scenario's own muscle models"},
                  {"--goniometer-csv", "a recorded goniometer drives an arm scenario's E4 (--experiment goniometer)"},
                  {"--gravity-identification", kIdentificationElsewhere},
                  {"--fault", "the creep experiment's plant changes are its creep: section's variants"}},
                 {},
                 experiments::run_creep_experiment}},
               check_creep, creep_board});
  r.push_back({"max_force_ramp", "one-DOF rig",
               "E5: the maximum-force test, one muscle ramped against the clamped rig (configs/e5_max_force.yaml)",
               {{"", "E5 maximum force",
                 {"--case", "--backend"},
                 {{"--agonist-calibration", "E5 tests the limits with the scenario's own muscle models (calibration files are for E1)"},
                  {"--antagonist-calibration", "E5 tests the limits with the scenario's own muscle models (calibration files are for E1)"},
                  {"--force-trim-rate", "E5 has no force controller: its input is a pressure ramp"},
                  {"--goniometer-csv", "a recorded goniometer drives an arm scenario's E4 (--experiment goniometer)"},
                  {"--gravity-identification", kIdentificationElsewhere}},
                 {},
                 experiments::run_e5_experiment}},
               check_e5, e5_board});
  r.push_back({"arm", "arm",
               "an arm or the upper body (configs/right_arm.yaml, configs/upper_body.yaml): E3 postures, E4 goniometer, E6 bandwidth (--experiment)",
               {{"postures", "E3 postures", {"--force-trim-rate", "--backend", "--gravity-identification", "--fault"},
                 arm_refusals({{"--case", "E3 runs every posture in one script (--case picks a movement of --experiment goniometer)"},
                               {"--goniometer-csv", kCsvElsewhere}}),
                 {{"--fault", "over the board the plant is the emulator's: give the faults in the scenario's faults: list"}},
                 [](const config::Document& doc, const experiments::RunRequest& request) {
                   return run_arm(doc, request, experiments::run_postures_experiment, "E3 (postures)", true);
                 }},
                {"goniometer", "E4 goniometer", {"--case", "--goniometer-csv", "--force-trim-rate", "--backend", "--gravity-identification"},
                 arm_refusals({{"--fault", kFaultsElsewhere}}),
                 {{"--goniometer-csv", "over the board the goniometer is the board's AD channel, in a replay the log's goniometer_deg; "
                                       "--goniometer-csv is for in-process runs on the simulated arm"}},
                 [](const config::Document& doc, const experiments::RunRequest& request) {
                   return run_arm(doc, request, experiments::run_goniometer_experiment, "E4 (goniometer)", false);
                 }},
                {"bandwidth", "E6 bandwidth", {"--force-trim-rate", "--gravity-identification"},
                 arm_refusals({{"--case", "E6 sweeps every frequency of the scenario (--case picks a movement of --experiment goniometer)"},
                               {"--goniometer-csv", kCsvElsewhere},
                               {"--backend", "E6 (--experiment bandwidth) runs in-process only: it needs the joint's true delivered "
                                             "torque, which no board sensor measures"},
                               {"--fault", kFaultsElsewhere}}),
                 {},
                 [](const config::Document& doc, const experiments::RunRequest& request) {
                   return run_arm(doc, request, run_bandwidth, "E6 (bandwidth)", false);
                 }}},
               check_arm, arm_board});
  return r;
}

}  // namespace

const std::vector<ExperimentEntry>& experiment_registry() {
  static const std::vector<ExperimentEntry> registry = make_registry();
  return registry;
}

const ExperimentEntry& find_experiment(const config::Document& doc) {
  std::vector<std::string> keys;
  for (const auto& e : experiment_registry()) keys.push_back(e.key);
  config::Map root = doc.root();
  const std::string key = root.choice("experiment", keys);  // throws, naming the known keys
  for (const auto& e : experiment_registry()) {
    if (e.key == key) return e;
  }
  throw std::logic_error("unreachable: the experiment key was checked");
}

}  // namespace peha::app
