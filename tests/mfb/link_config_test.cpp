// The mfb: section on one board or several: every io joint on exactly one board, each map fitting
// one board (16 AD, 8 DA, 8 encoders); the refusals name the file, the field, what was expected and
// what was found.
#include "peha/hardware/door.hpp"
#include "peha/mfb/link_config.hpp"

#include "peha/experiments/arm/arm_scenario.hpp"
#include "../support/replaced.hpp"

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace peha::mfb {
namespace {

using ::testing::HasSubstr;

const std::vector<std::string> kUpperBody = {"R_SAA", "R_SFE", "R_EFE", "R_WFE", "L_SAA", "L_SFE", "L_EFE", "L_WFE"};
const std::string kMaps = PEHA_SOURCE_DIR "/configs/mfb/";

/// `section` with its relative channel_map and key_file paths made absolute in configs/mfb.
std::string in_maps_folder(std::string section) {
  for (const std::string key : {"channel_map: ", "key_file: "}) {
    for (auto at = section.find(key); at != std::string::npos; at = section.find(key, at + key.size())) {
      if (section[at + key.size()] != '/') section.insert(at + key.size(), kMaps);
    }
  }
  return section;
}

/// An mfb: section, map names relative to configs/mfb.
LinkConfig read(const std::string& section, const std::vector<std::string>& io_joints = kUpperBody) {
  const config::Document doc = config::Document::load_string("mfb:\n" + in_maps_folder(section), kMaps + "scenario.yaml");
  config::Map root = doc.root();
  return read_link_config(root.map("mfb"), io_joints);
}

/// The message of the config::Error `section` raises ("" if none).
std::string refusal(const std::string& section, const std::vector<std::string>& io_joints = kUpperBody) {
  try {
    read(section, io_joints);
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

/// The link's settings after its board list, as the shipped scenarios have them.
const std::string kLinkSettings = R"(  key_file: dev_link.key
  board_watchdog_ms: 50.0
  receive_timeout_ms: 0.8
  vent_s: 2.0
)";

const std::string kThreeBoards = R"(  boards:
    - {name: right, channel_map: upper_body_right.yaml}
    - {name: left, channel_map: upper_body_left.yaml}
    - {name: shoulders, channel_map: upper_body_shoulders.yaml}
)" + kLinkSettings;

using testing::replaced;

TEST(LinkConfig, SingleBoardFormDrivesEveryIoJointOnOneBoard) {
  const LinkConfig l = read("  channel_map: right_arm.yaml\n" + kLinkSettings, {"R_SFE", "R_EFE", "R_WFE"});
  ASSERT_EQ(l.boards.size(), 1u);
  EXPECT_EQ(l.boards[0].name, "");
  EXPECT_EQ(l.boards[0].joint_names, (std::vector<std::string>{"R_SFE", "R_EFE", "R_WFE"}));
  EXPECT_EQ(l.channel_map, l.boards[0].channel_map);
  EXPECT_EQ(l.key_file, l.boards[0].key_file);
}

TEST(LinkConfig, UpperBodySplitsItsJointsOverThreeBoardsInIoOrder) {
  const LinkConfig l = read(kThreeBoards);
  ASSERT_EQ(l.boards.size(), 3u);
  EXPECT_EQ(l.boards[0].joint_names, (std::vector<std::string>{"R_SFE", "R_EFE", "R_WFE"}));
  EXPECT_EQ(l.boards[1].joint_names, (std::vector<std::string>{"L_SFE", "L_EFE", "L_WFE"}));
  EXPECT_EQ(l.boards[2].joint_names, (std::vector<std::string>{"R_SAA", "L_SAA"}));
  for (const BoardLink& b : l.boards) EXPECT_EQ(b.key_file, std::filesystem::path(kMaps + "dev_link.key")) << b.name;
  // The shipped scenario reads the same way.
  const experiments::ArmScenario s =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  ASSERT_TRUE(s.link);
  ASSERT_EQ(s.link->boards.size(), 3u);
  EXPECT_EQ(s.link->boards[2].name, "shoulders");
}

TEST(LinkConfig, RefusesAnIoJointOnNoBoard) {
  const std::string e = refusal(replaced(kThreeBoards, "    - {name: shoulders, channel_map: upper_body_shoulders.yaml}\n", ""));
  EXPECT_THAT(e, HasSubstr("scenario.yaml"));
  EXPECT_THAT(e, HasSubstr("mfb.boards"));
  EXPECT_THAT(e, HasSubstr("io joint 'R_SAA' is on no board"));
  EXPECT_THAT(e, HasSubstr("expected every io joint"));
}

TEST(LinkConfig, RefusesAnIoJointOnTwoBoards) {
  const std::string e = refusal(replaced(kThreeBoards, "    - {name: left, channel_map: upper_body_left.yaml}\n",
                                         "    - {name: left, channel_map: upper_body_left.yaml}\n"
                                         "    - {name: right_again, channel_map: upper_body_right.yaml}\n"));
  EXPECT_THAT(e, HasSubstr("mfb.boards"));
  EXPECT_THAT(e, HasSubstr("io joint 'R_SFE' is on two boards: 'right'"));
  EXPECT_THAT(e, HasSubstr("'right_again'"));
}

// One board per arm: an arm's four joints need 11 DA channels (8 valves, 3 motors) and 16 AD
// channels for its load cells and pressures; a board has 8 DA.
TEST(LinkConfig, RefusesAMapThatDoesNotFitOneBoard) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("peha_link_config_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream map(dir / "whole_right_arm.yaml");
  map << "analog_inputs:\n";
  int ad = 0;
  for (const char* j : {"R_SAA", "R_SFE", "R_EFE", "R_WFE"}) {
    for (const char* q : {"agonist_loadcell", "antagonist_loadcell", "agonist_pressure", "antagonist_pressure"}) {
      map << "  - {channel: " << ad++ << ", signal: " << j << "." << q << ", unit: N, range: [0, 1000]}\n";
    }
  }
  map << "analog_outputs:\n";
  int da = 0;
  for (const char* j : {"R_SAA", "R_SFE", "R_EFE", "R_WFE"}) {
    for (const char* q : {"agonist_valve", "antagonist_valve"}) map << "  - {channel: " << da++ << ", signal: " << j << "." << q << ", unit: MPa, range: [0, 1]}\n";
  }
  for (const char* j : {"R_SAA", "R_SFE", "R_EFE"}) map << "  - {channel: " << da++ << ", signal: " << j << ".motor, unit: Nm, scale: 1.0e-4, offset: -3.2768}\n";
  map << "encoders:\n";
  int enc = 0;
  for (const char* j : {"R_SAA", "R_SFE", "R_EFE", "R_WFE"}) map << "  - {channel: " << enc++ << ", joint: " << j << ", counts_per_rev: 2000, gear: 35, sign: 1, offset_deg: 0}\n";
  map << "digital:\n  enable_output: {line: 0, active: high}\n  estop_input: {line: 0, active: low}\n";
  map.close();
  const std::string e = refusal(replaced(replaced(kThreeBoards, "channel_map: upper_body_right.yaml", "channel_map: " + (dir / "whole_right_arm.yaml").string()),
                                         "    - {name: shoulders, channel_map: upper_body_shoulders.yaml}\n", ""));
  EXPECT_THAT(e, HasSubstr("whole_right_arm.yaml"));
  EXPECT_THAT(e, HasSubstr("analog_outputs"));
  EXPECT_THAT(e, HasSubstr("board 'right' does not fit one board: it has 8 DA channels, this map asks for 11"));
  std::filesystem::remove_all(dir);
}

TEST(LinkConfig, RefusesAMapJointThatIsNoIoJoint) {
  const std::string e = refusal(kThreeBoards, {"R_SAA", "R_SFE", "R_EFE", "L_SAA", "L_SFE", "L_EFE", "L_WFE"});
  EXPECT_THAT(e, HasSubstr("upper_body_right.yaml"));
  EXPECT_THAT(e, HasSubstr("encoders[2].joint"));
  EXPECT_THAT(e, HasSubstr("'R_WFE' is not an io joint of the scenario"));
}

TEST(LinkConfig, RefusesAmbiguousOrIncompleteBoardLists) {
  EXPECT_THAT(refusal("  channel_map: right_arm.yaml\n" + kThreeBoards), HasSubstr("either channel_map (one board) or boards (several)"));
  EXPECT_THAT(refusal(replaced(kThreeBoards, "name: left", "name: right")), HasSubstr("board name 'right' appears twice"));
  EXPECT_THAT(refusal(replaced(kThreeBoards, "  key_file: dev_link.key\n", "")), HasSubstr("missing key_file"));
  EXPECT_THAT(refusal(replaced(kThreeBoards, "{name: left,", "{nam: left,")), HasSubstr("name"));
}

TEST(LinkConfig, EachBoardMayHaveItsOwnKey) {
  const LinkConfig l = read(replaced(kThreeBoards, "{name: left, channel_map: upper_body_left.yaml}",
                                     "{name: left, channel_map: upper_body_left.yaml, key_file: other.key}"));
  EXPECT_EQ(l.boards[1].key_file, std::filesystem::path(kMaps + "other.key"));
  EXPECT_EQ(l.boards[0].key_file, std::filesystem::path(kMaps + "dev_link.key"));
}

TEST(LinkConfig, BoardAddressesAreOnePerBoardOrConsecutivePorts) {
  const LinkConfig l = read(kThreeBoards);
  const io::UdpEndpoint a = io::parse_udp_endpoint("udp://127.0.0.1:9000");
  const std::vector<io::UdpEndpoint> consecutive = board_endpoints(l, {a});
  ASSERT_EQ(consecutive.size(), 3u);
  EXPECT_EQ(consecutive[2].port, 9002);
  EXPECT_EQ(consecutive[2].address, a.address);
  const std::vector<io::UdpEndpoint> given = {a, io::parse_udp_endpoint("udp://10.0.0.2:50000"), io::parse_udp_endpoint("udp://10.0.0.3:50000")};
  EXPECT_EQ(board_endpoints(l, given), given);
  try {
    board_endpoints(l, {a, a});
    FAIL() << "two addresses for three boards";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("the scenario has 3 board(s); expected 3 address(es)"));
    EXPECT_THAT(e.what(), HasSubstr("found 2"));
  }
}

// The host's watchdog and the recovery ramp are the lifecycle supervisor's (the scenario's
// lifecycle:, in process too): an older mfb: section that still has them is refused, naming where
// they went, instead of being half read.
TEST(LinkConfig, TheLifecycleKeysOfAnOlderSectionAreRefusedNamingTheirNewPlace) {
  EXPECT_THAT(refusal("  channel_map: right_arm.yaml\n" + kLinkSettings + "  host_watchdog_ms: 20.0\n", {"R_SFE", "R_EFE", "R_WFE"}),
              HasSubstr("mfb.host_watchdog_ms: this key moved: give it as lifecycle.host_watchdog_ms"));
  EXPECT_THAT(refusal("  channel_map: right_arm.yaml\n" + kLinkSettings + "  recovery_ramp_s: 1.0\n", {"R_SFE", "R_EFE", "R_WFE"}),
              HasSubstr("mfb.recovery_ramp_s: this key moved: give it as lifecycle.recovery_ramp_s"));
}

TEST(LinkConfig, OneBoardExperimentsRefuseSeveralBoards) {
  const LinkConfig l = read(kThreeBoards);
  hardware::HardwareRequest request;
  request.joint_names = kUpperBody;
  request.link = &l;
  request.one_board = true;
  try {
    (void)hardware::open_backend(hardware::BackendUri::parse("udp://127.0.0.1:9000"), request);
    FAIL() << "a one-board experiment opened three boards";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("this experiment runs on one board; the scenario's mfb: section has 3"));
  }
}

}  // namespace
}  // namespace peha::mfb
