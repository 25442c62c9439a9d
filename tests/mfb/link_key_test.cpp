// The link's key file (mfb::load_link_key, docs/mfb-protocol.md#authentication): 64 hex digits,
// owner-only, never all zero; every refusal names the file and the fix.
#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace peha::mfb {
namespace {

using ::testing::HasSubstr;

class LinkKeyFile : public ::testing::Test {
 protected:
  // One folder per test and process: ctest runs these tests in parallel, and one test's TearDown
  // must not remove the folder another is writing into.
  std::filesystem::path dir_ = std::filesystem::temp_directory_path() /
                               ("peha_link_key_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
                                "_" + std::to_string(::getpid()));
  void SetUp() override { std::filesystem::create_directories(dir_); }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path write(const std::string& name, const std::string& text,
                              std::filesystem::perms mode = std::filesystem::perms::owner_read | std::filesystem::perms::owner_write) {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p) << text;
    std::filesystem::permissions(p, mode);
    return p;
  }
  std::string refusal(const std::filesystem::path& p) {
    try {
      load_link_key(p);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(accepted)";
  }
};

TEST_F(LinkKeyFile, ReadsSixtyFourHexDigitsWithCommentsAndWhitespace) {
  const LinkKey k = load_link_key(write("k", "# a comment\n  000102030405060708090a0b0c0d0e0f\n101112131415161718191A1B1C1D1E1F  \n"));
  for (std::size_t i = 0; i < kKeySize; ++i) EXPECT_EQ(k.bytes[i], i) << i;
}

TEST_F(LinkKeyFile, RefusesAFileGroupOrOthersMayRead) {
  const std::string hex(64, 'a');
  using std::filesystem::perms;
  const std::string why = refusal(write("k", hex, perms::owner_read | perms::owner_write | perms::group_read));
  EXPECT_THAT(why, HasSubstr("accessible by group or others"));
  EXPECT_THAT(why, HasSubstr("chmod 600"));
  EXPECT_THAT(why, HasSubstr((dir_ / "k").string()));
  EXPECT_THAT(refusal(write("w", hex, perms::owner_read | perms::others_read)), HasSubstr("(mode 0404)"));
}

TEST_F(LinkKeyFile, RefusesAWrongLengthNonHexAZeroKeyAndAMissingFile) {
  EXPECT_THAT(refusal(write("short", std::string(62, 'a'))), HasSubstr("expected exactly 64 hex digits"));
  EXPECT_THAT(refusal(write("long", std::string(66, 'a'))), HasSubstr("found 66 characters"));
  EXPECT_THAT(refusal(write("nonhex", std::string(63, 'a') + "g")), HasSubstr("hex digits"));
  EXPECT_THAT(refusal(write("zero", std::string(64, '0'))), HasSubstr("all zero"));
  EXPECT_THAT(refusal(dir_ / "missing"), HasSubstr("No such file"));
}

// A typed key has few distinct bytes; 32 random bytes have about 30. The line is at 8.
TEST_F(LinkKeyFile, RefusesAKeyOfLowEntropy) {
  std::string seven, eight;
  for (int i = 0; i < 32; ++i) seven += fmt::format("{:02x}", i % 7);
  for (int i = 0; i < 32; ++i) eight += fmt::format("{:02x}", i % 8);
  const std::string why = refusal(write("repeated", std::string(64, 'a')));
  EXPECT_THAT(why, HasSubstr("low entropy (1 distinct byte value(s), expected at least 8"));
  EXPECT_THAT(why, HasSubstr("peha keygen"));
  EXPECT_THAT(refusal(write("seven", seven)), HasSubstr("7 distinct"));
  EXPECT_EQ(refusal(write("eight", eight)), "(accepted)");
}

TEST_F(LinkKeyFile, KeygenWritesAnOwnerOnlyKeyThatLoadsAndDiffersEachTime) {
  write_new_link_key(dir_ / "a.key");
  write_new_link_key(dir_ / "b.key");
  EXPECT_EQ(std::filesystem::status(dir_ / "a.key").permissions() & std::filesystem::perms::all,
            std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  const LinkKey a = load_link_key(dir_ / "a.key"), b = load_link_key(dir_ / "b.key");
  EXPECT_NE(a.bytes, b.bytes);
  EXPECT_FALSE(is_development_key(a));
}

TEST_F(LinkKeyFile, KeygenRefusesToOverwriteAnExistingFile) {
  const std::filesystem::path p = write("old.key", "precious");
  try {
    write_new_link_key(p);
    ADD_FAILURE() << "overwrote " << p;
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("exists; refusing to overwrite"));
  }
  std::ifstream in(p);
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "precious");
}

// The development key is public: it may drive a board only on this machine (127.0.0.0/8).
TEST_F(LinkKeyFile, TheDevelopmentKeyIsRefusedForABoardOffLoopback) {
  const LinkKey dev = load_link_key(PEHA_SOURCE_DIR "/configs/mfb/dev_link.key");
  ASSERT_TRUE(is_development_key(dev));
  EXPECT_NO_THROW(require_private_key_off_loopback(dev, 0x7F000001u, "board"));
  EXPECT_NO_THROW(require_private_key_off_loopback(dev, 0x7F010203u, "board"));
  try {
    require_private_key_off_loopback(dev, 0xC0A80017u, "board");
    ADD_FAILURE() << "the development key was accepted for 192.168.0.23";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("board address 192.168.0.23 is not loopback"));
    EXPECT_THAT(e.what(), HasSubstr("peha keygen --out FILE"));
  }
  EXPECT_THROW(require_private_key_off_loopback(dev, 0, "emulator's bind"), std::runtime_error);  // 0.0.0.0: every interface
  write_new_link_key(dir_ / "own.key");
  EXPECT_NO_THROW(require_private_key_off_loopback(load_link_key(dir_ / "own.key"), 0xC0A80017u, "board"));
}

// The shipped development key (what the scenarios and the tests use) is valid and owner-only
// (CMake's configure step sets its mode: git keeps none).
TEST_F(LinkKeyFile, TheShippedDevelopmentKeyLoads) {
  EXPECT_NO_THROW(load_link_key(PEHA_SOURCE_DIR "/configs/mfb/dev_link.key"));
}

}  // namespace
}  // namespace peha::mfb
