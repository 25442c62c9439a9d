#pragma once
// A shipped scenario, edited, in a private directory: the tests that check how a config is read or
// refused write a changed copy of configs/<name> beside links to the folders it names (arm/, plant/,
// mfb/), so its relative paths still resolve.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

namespace peha::testing {

class EditedConfig {
 public:
  /// `name`: the shipped file under configs/ (e.g. "right_arm.yaml"); `tag`: this test's directory.
  EditedConfig(const std::string& name, const std::string& tag)
      : dir_(std::filesystem::temp_directory_path() / ("peha_" + tag + "_" + std::to_string(::getpid()))), name_(name) {
    std::filesystem::create_directories(dir_);
    for (const char* sub : {"arm", "plant", "mfb"}) {
      std::error_code ignored;  // a link left by an earlier run of this test is as good
      std::filesystem::create_directory_symlink(std::filesystem::path(PEHA_SOURCE_DIR) / "configs" / sub, dir_ / sub, ignored);
    }
    std::ifstream in(std::filesystem::path(PEHA_SOURCE_DIR) / "configs" / name);
    std::stringstream text;
    text << in.rdbuf();
    shipped_ = text.str();
  }
  ~EditedConfig() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  EditedConfig(const EditedConfig&) = delete;
  EditedConfig& operator=(const EditedConfig&) = delete;

  const std::string& shipped() const { return shipped_; }
  /// Writes `text` as the scenario and returns its path.
  std::filesystem::path write(const std::string& text) const {
    std::ofstream(dir_ / name_) << text;
    return dir_ / name_;
  }
  /// The shipped text with the first `from` replaced by `to` (empty when `from` is not there), written.
  std::filesystem::path write_replacing(const std::string& from, const std::string& to, bool* found = nullptr) const {
    std::string text = shipped_;
    const std::size_t at = text.find(from);
    if (found) *found = at != std::string::npos;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return write(text);
  }

 private:
  std::filesystem::path dir_;
  std::string name_;
  std::string shipped_;
};

}  // namespace peha::testing
