// Every procedure through the one hardware door, end to end over UDP against `peha mfb-emulator` in
// its own process: the paper's calibration (record both muscles on the board, calibrate, run E1 with
// the calibration on the board) and the arm's gravity identification (identify on the board, run E3
// with it on the board), each against the same chain in process. The excitations and the
// identification's postures are shortened (the shipped ones take 85-135 s of real time each). They
// run beside the unit tests, not serially as the *_e2e timing tests: what they judge (figures of
// the chain against the process's, with the tests' 250 ms watchdogs) does not hang on the machine's
// timing, and serially they took 2 of make test's minutes.
#include "peha/experiments/e1_gravity/e1_realtime.hpp"
#include "peha/experiments/e1_gravity/e1_report.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/experiments/e3_postures/postures_realtime.hpp"
#include "peha/hardware/door.hpp"
#include "peha/runtime/child_process.hpp"
#include "peha/runtime/csv_log.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace peha::experiments {
namespace {

/// A private folder with links to the folders the shipped configs name.
std::filesystem::path test_dir(const std::string& tag) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_door_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  for (const char* sub : {"arm", "plant", "mfb"}) std::filesystem::create_directory_symlink(PEHA_SOURCE_DIR "/configs/" + std::string(sub), dir / sub);
  return dir;
}

/// Runs `peha args...` to its end (at most `timeout_s`): its exit status, its output in `output`.
int peha(const std::vector<std::string>& args, std::string& output, double timeout_s = 120.0) {
  std::vector<std::string> argv = {PEHA_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  runtime::ChildProcess p(argv);
  const int status = p.wait(timeout_s);
  output = p.output();
  return status;
}

/// `peha mfb-emulator` serving `config`'s plant `case_name` on a free port; test watchdogs (the
/// machine is shared: 250 ms, as the other end-to-end tests).
struct Emulator {
  runtime::ChildProcess process;
  int port = 0;
  Emulator(const std::filesystem::path& config, const std::string& case_name)
      : process({PEHA_BINARY, "mfb-emulator", "--config", config.string(), "--port", "0", "--case", case_name, "--rt-priority", "0",
                 "--watchdog-ms", "250"}) {
    port = runtime::parse_listening_port(process.wait_for_line("listening on", 20.0));
  }
  std::string uri() const { return "udp://127.0.0.1:" + std::to_string(port); }
};

HardwareRunOptions board_options(const Emulator& emulator, const std::filesystem::path& dir) {
  HardwareRunOptions o;
  o.backend = hardware::BackendUri::parse(emulator.uri());
  o.realtime.fifo_priority = 0;  // tests share the machine: no SCHED_FIFO
  o.realtime.lock_memory = false;
  o.quiet = true;
  o.dir = dir;
  std::filesystem::create_directories(dir);
  return o;
}

// E1's calibration chain on the board and in process. Each recording is the shipped excitation cut
// to one 12 s triangle and 4 s operating-point segments (25 s and 33 s, both muscles recorded at
// once on two emulated boards); then `peha calibrate` on each, and E1's first case with the
// calibrated parametric + SPGP model on the paper's pure feed-forward, on a fresh board. The board's
// chain differs from the process's by the DA/AD quantisation, packets held for a cycle and the board's
// plant stepping a period on its own when a command is late; what E1 judges must agree.
TEST(ProceduresOverTheBoard, RecordCalibrateAndRunE1AsInProcess) {
  const std::filesystem::path dir = test_dir("calibration");
  YAML::Node root = YAML::LoadFile(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml");
  root["plant"]["model"] = PEHA_SOURCE_DIR "/models/one_dof_rig.xml";
  root["lifecycle"]["host_watchdog_ms"] = 250.0;
  for (const char* m : {"agonist", "antagonist"}) {
    YAML::Node c = root["calibration"][m];
    c["duration_s"] = 12.0;
    for (YAML::Node g : c["operating_points"]) g["period_s"] = g["duration_s"] = 4.0;
  }
  // E1 up to the end of the second release's drift window (23 s): the breakaway probes after it
  // need the plant's finger force, which the board does not measure.
  root["run"]["duration_s"] = 23.0;
  YAML::Node pushes(YAML::NodeType::Sequence);
  for (YAML::Node p : root["finger"]["pushes"]) {
    if (!p["breakaway"]) pushes.push_back(p);
  }
  root["finger"]["pushes"] = pushes;
  const std::filesystem::path config = dir / "e1_short.yaml";
  std::ofstream(config) << YAML::Dump(root) << "\n";

  std::string out;
  for (const char* m : {"agonist", "antagonist"}) {
    ASSERT_EQ(peha({"record-calibration", "--config", config.string(), "--muscle", m, "--out", (dir / "sim" / (std::string(m) + ".csv")).string()}, out), 0) << out;
  }
  {
    Emulator agonist_board(config, "calibration_agonist"), antagonist_board(config, "calibration_antagonist");
    ASSERT_GT(agonist_board.port, 0) << agonist_board.process.output();
    ASSERT_GT(antagonist_board.port, 0) << antagonist_board.process.output();
    runtime::ChildProcess agonist({PEHA_BINARY, "record-calibration", "--config", config.string(), "--muscle", "agonist", "--out",
                                   (dir / "board" / "agonist.csv").string(), "--backend", agonist_board.uri(), "--rt-priority", "0"});
    runtime::ChildProcess antagonist({PEHA_BINARY, "record-calibration", "--config", config.string(), "--muscle", "antagonist", "--out",
                                      (dir / "board" / "antagonist.csv").string(), "--backend", antagonist_board.uri(), "--rt-priority", "0"});
    ASSERT_EQ(agonist.wait(120.0), 0) << agonist.output();
    ASSERT_EQ(antagonist.wait(120.0), 0) << antagonist.output();
    EXPECT_NE(agonist.output().find("inactive -> finalized (run ended)"), std::string::npos) << agonist.output();
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "board" / "agonist.cycles.csv"));  // the board's per-cycle log beside the data
  for (const char* where : {"sim", "board"}) {
    for (const char* m : {"antagonist", "agonist"}) {
      const std::filesystem::path d = dir / where;
      ASSERT_EQ(peha({"calibrate", (d / (std::string(m) + ".csv")).string(), "--muscle", m, "--out", (d / (std::string(m) + ".yaml")).string(), "--no-plot"}, out), 0)
          << where << " " << m << ": " << out;
    }
  }

  E1Scenario s = read_e1(config::Document::load_file(config));
  s.controller.allocation.force_trim_rate_1ps = 0.0;  // the paper's pure feed-forward: the calibration alone
  const E1Case& c = s.cases.front();
  auto spgp_variant = [&](const char* where) {
    const std::filesystem::path files[2] = {dir / where / "agonist.yaml", dir / where / "antagonist.yaml"};
    for (const E1Variant& v : e1_variants(s, files)) {
      if (v.label == "spgp") return v.scenario;
    }
    throw std::runtime_error("no spgp variant");
  };
  // In process with the simulator's truth: the static torque error needs it (over the board the
  // breakaway probes' finger force is the plant's, not a sensor's).
  auto in_process = [&](const E1Scenario& scenario) {
    const hardware::Hardware rig = hardware::open_backend(hardware::BackendUri{}, e1_hardware(scenario, c));
    return run_e1_on(scenario, c, *rig.backend, dynamic_cast<sim::OneDofRigBackend*>(rig.backend.get()), nullptr);
  };
  // The largest static torque error at rest after a release (plant truth, % of the gravity torque).
  auto static_error_pct = [](const E1Result& r) {
    double worst = 0;
    for (const E1Release& rel : r.releases) worst = std::max(worst, std::abs(rel.static_torque_error_pct));
    return worst;
  };
  const E1Result local = in_process(spgp_variant("sim"));
  const E1Result board_calibration = in_process(spgp_variant("board"));
  Emulator rig_board(config, c.name);
  ASSERT_GT(rig_board.port, 0) << rig_board.process.output();
  const E1RealtimeResult udp = run_e1_realtime(spgp_variant("board"), c, board_options(rig_board, dir / "e1_board"));

  EXPECT_EQ(udp.faults, 0u);
  std::printf("calibrated E1 (%s), in process vs over the board: force tracking RMS %.1f / %.1f N vs %.1f / %.1f N; verdict %s vs %s; "
              "largest static torque error (plant truth, in process) with the process's calibration %+.2f %%, with the board's %+.2f %%\n",
              c.name.c_str(), local.force_tracking_rms_N[0], local.force_tracking_rms_N[1], udp.e1.force_tracking_rms_N[0],
              udp.e1.force_tracking_rms_N[1], local.within_limits ? "OK" : "FAIL", udp.e1.within_limits ? "OK" : "FAIL",
              static_error_pct(local), static_error_pct(board_calibration));
  RecordProperty("force_tracking_rms_agonist_N_udp", std::to_string(udp.e1.force_tracking_rms_N[0]));
  RecordProperty("static_error_pct_board_calibration", std::to_string(static_error_pct(board_calibration)));
  // Tolerances: each muscle's force tracking within 10 N or 30 % of the process's; the static torque
  // error of the board's calibration within 2 points of the process's (the verdict allows 5 %).
  for (int m = 0; m < 2; ++m) {
    EXPECT_NEAR(udp.e1.force_tracking_rms_N[m], local.force_tracking_rms_N[m], std::max(10.0, 0.3 * local.force_tracking_rms_N[m])) << m;
  }
  EXPECT_NEAR(static_error_pct(board_calibration), static_error_pct(local), 2.0);
  EXPECT_TRUE(board_calibration.within_limits) << board_calibration.verdict.failures();
  EXPECT_EQ(udp.e1.within_limits, local.within_limits) << udp.e1.verdict.failures() << "\nin process:\n" << local.verdict.failures();
  ASSERT_EQ(udp.e1.releases.size(), local.releases.size());
  for (std::size_t i = 0; i < local.releases.size(); ++i) EXPECT_NEAR(udp.e1.releases[i].angle_deg, local.releases[i].angle_deg, 1.0) << i;
  std::filesystem::remove_all(dir);
}

// The rig's procedure key (a key switch at the board) switches the board's range vent off for a
// procedure that drives the link onto its stops. The host refuses a run with the key turned and the
// recording without it, at the handshake: nothing is armed, nothing written.
TEST(ProceduresOverTheBoard, TheProcedureKeyIsTurnedForTheRecordingAndForNothingElse) {
  const std::filesystem::path dir = test_dir("procedure_key");
  const std::string config = PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml";
  std::string out;
  {
    Emulator turned(config, "calibration_agonist");  // the emulator's recording rig: the key turned
    ASSERT_GT(turned.port, 0) << turned.process.output();
    const int status = peha({"run", "--config", config, "--case", "payload_2.5kg", "--backend", turned.uri(), "--rt-priority", "0", "--no-plot", "--out",
                             dir.string(), "--name", "keyed"},
                            out);
    EXPECT_NE(status, 0) << out;
    EXPECT_NE(out.find("(input line 1) is turned: with it the board's range does not vent"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(dir / "keyed"));
  }
  {
    Emulator rig(config, "payload_2.5kg");  // a run's rig: the key not turned
    ASSERT_GT(rig.port, 0) << rig.process.output();
    const int status = peha({"record-calibration", "--config", config, "--muscle", "agonist", "--out", (dir / "agonist.csv").string(),
                             "--backend", rig.uri(), "--rt-priority", "0"},
                            out);
    EXPECT_NE(status, 0) << out;
    EXPECT_NE(out.find("turn the procedure key at the MFB"), std::string::npos) << out;
    EXPECT_FALSE(std::filesystem::exists(dir / "agonist.csv"));
  }
  std::filesystem::remove_all(dir);
}

// The arm's gravity identification on the board and in process: the shipped procedure cut to four
// postures (44 s of real time on the rig), then E3 at one posture (elbow_90, 3 s of watching) with
// each identification. The identification over the board must give the controller a gravity model
// as right as the process's (plant truth, in process), and E3 on the board with it must hold as E3
// in process does.
TEST(ProceduresOverTheBoard, IdentifyGravityAndRunE3AsInProcess) {
  const std::filesystem::path dir = test_dir("identification");
  YAML::Node root = YAML::LoadFile(PEHA_SOURCE_DIR "/configs/right_arm.yaml");
  root["lifecycle"]["host_watchdog_ms"] = 250.0;
  YAML::Node four(YAML::NodeType::Sequence);
  for (YAML::Node p : root["identification"]["postures"]) {
    const std::string name = p["name"].as<std::string>();
    if (name == "forward_15" || name == "elbow_90" || name == "raised_flexed" || name == "low_flexed") four.push_back(p);
  }
  root["identification"]["postures"] = four;
  YAML::Node one(YAML::NodeType::Sequence);
  one.push_back(root["postures"]["list"][3]);  // elbow_90
  root["postures"]["list"] = one;
  root["postures"]["observe_s"] = 3.0;
  // Four postures identify the elbow less well at the hanging pose than the shipped eight: at the
  // refill its motor steps to -2.5 Nm and jolts the held elbow 0.47 deg at 11 deg/s, over the start-up
  // figure's 10 deg/s (the figure catching a poor model, in process and on the board alike). This test
  // compares the board with the process, so that figure's limit is raised here, for both.
  root["verdict"]["max_startup_speed_degps"] = 20.0;
  const std::filesystem::path config = dir / "right_arm_short.yaml";
  std::ofstream(config) << YAML::Dump(root) << "\n";

  std::string out;
  ASSERT_EQ(peha({"identify-gravity", "--config", config.string(), "--out", (dir / "sim" / "gravity.yaml").string()}, out), 0) << out;
  {
    Emulator board(config, "identification");
    ASSERT_GT(board.port, 0) << board.process.output();
    ASSERT_EQ(peha({"identify-gravity", "--config", config.string(), "--out", (dir / "board" / "gravity.yaml").string(), "--backend", board.uri(),
                    "--rt-priority", "0"}, out), 0)
        << out;
    EXPECT_NE(out.find("inactive -> finalized (run ended)"), std::string::npos) << out;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "board" / "gravity.cycles.csv"));

  ArmScenario s = read_arm_scenario(config::Document::load_file(config));
  ASSERT_EQ(s.postures.size(), 1u);
  auto with = [&](const char* where) {
    ArmScenario w = s;
    use_gravity_identification(w, dir / where / "gravity.yaml");
    return w;
  };
  auto in_process = [&](const ArmScenario& scenario) {
    const hardware::Hardware arm = hardware::open_backend(hardware::BackendUri{}, arm_hardware(scenario, postures_plant_params(scenario)));
    return run_postures_on(scenario, *arm.backend, dynamic_cast<sim::ArmBackend*>(arm.backend.get()), nullptr);
  };
  const PosturesResult local = in_process(with("sim"));
  const PosturesResult board_identification = in_process(with("board"));
  Emulator arm_board(config, "postures");
  ASSERT_GT(arm_board.port, 0) << arm_board.process.output();
  const PosturesRealtimeResult udp = run_postures_realtime(with("board"), board_options(arm_board, dir / "e3_board"));
  EXPECT_EQ(udp.faults, 0u);

  const PostureResult& a = local.postures.at(0);
  const PostureResult& b = board_identification.postures.at(0);
  const PostureResult& u = udp.postures.postures.at(0);
  ASSERT_EQ(a.joints.size(), b.joints.size());
  ASSERT_EQ(a.joints.size(), u.joints.size());
  for (std::size_t j = 0; j < a.joints.size(); ++j) {
    std::printf("E3 %s %s: model gravity error (plant truth) %+.2f %% with the process's identification, %+.2f %% with the board's; "
                "static torque error %+.2f / %+.2f %%; released %.2f deg in process, %.2f deg over the board; drift %.3f / %.3f deg\n",
                a.name.c_str(), a.joints[j].joint.c_str(), a.joints[j].model_gravity_error_pct, b.joints[j].model_gravity_error_pct,
                a.joints[j].static_torque_error_pct, b.joints[j].static_torque_error_pct, a.joints[j].released_deg, u.joints[j].released_deg,
                a.joints[j].drift_deg, u.joints[j].drift_deg);
    // Tolerances: the identified model within 2 points of gravity of the process's; E3 on the board
    // released within 0.5 deg and drifting within 0.2 deg of E3 in process.
    EXPECT_NEAR(b.joints[j].model_gravity_error_pct, a.joints[j].model_gravity_error_pct, 2.0) << a.joints[j].joint;
    EXPECT_NEAR(b.joints[j].static_torque_error_pct, a.joints[j].static_torque_error_pct, 2.0) << a.joints[j].joint;
    EXPECT_NEAR(u.joints[j].released_deg, a.joints[j].released_deg, 0.5) << a.joints[j].joint;
    EXPECT_NEAR(u.joints[j].drift_deg, a.joints[j].drift_deg, 0.2) << a.joints[j].joint;
  }
  EXPECT_TRUE(board_identification.within_limits) << board_identification.verdict.failures();
  EXPECT_EQ(udp.postures.within_limits, local.within_limits) << udp.postures.verdict.failures() << "\nin process:\n" << local.verdict.failures();
  std::filesystem::remove_all(dir);
}

// A user's own controller (examples/pd_gravity.cpp through peha::api::Exoskeleton::control) as a
// lab runs it: on the simulated arm, then on the board against `peha mfb-emulator --case free` (the
// arm alone). Both hold the arm through the start-up, follow a 10 deg move and pass the verdict.
TEST(UserControllerOverTheBoard, ThePdExampleRunsOnTheSimulatorAndOnTheBoard) {
  const std::filesystem::path dir = test_dir("user_controller");
  YAML::Node root = YAML::LoadFile(PEHA_SOURCE_DIR "/configs/right_arm.yaml");
  root["lifecycle"]["host_watchdog_ms"] = 250.0;
  const std::filesystem::path config = dir / "right_arm.yaml";
  std::ofstream(config) << YAML::Dump(root) << "\n";
  auto example = [&](const std::vector<std::string>& extra, std::string& output) {
    std::vector<std::string> argv = {PEHA_PD_EXAMPLE, "--config", config.string()};
    argv.insert(argv.end(), extra.begin(), extra.end());
    runtime::ChildProcess p(argv);
    const int status = p.wait(60.0);
    output = p.output();
    return status;
  };
  std::string sim, board;
  EXPECT_EQ(example({"--log", (dir / "sim.csv").string()}, sim), 0) << sim;
  EXPECT_NE(sim.find("verdict: PASSED"), std::string::npos) << sim;
  Emulator arm(config, "free");
  ASSERT_GT(arm.port, 0) << arm.process.output();
  EXPECT_EQ(example({"--backend", arm.uri(), "--rt-priority", "0", "--log", (dir / "board.csv").string()}, board), 0) << board;
  EXPECT_NE(board.find("verdict: PASSED"), std::string::npos) << board;
  std::printf("%s\n%s\n", sim.c_str(), board.c_str());
  // The board run's log is the same format, and replayable: the sensors of every joint are in it.
  const auto cols = runtime::read_csv_log_columns(dir / "board.csv", {"t_s", "efe_angle_rad", "efe_agonist_pressure_MPa"});
  EXPECT_GT(cols[0].size(), 5000u);
  EXPECT_EQ(cols[1].size(), cols[0].size());
  EXPECT_EQ(cols[2].size(), cols[0].size());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace peha::experiments
