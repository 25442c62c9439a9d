#pragma once
/// \file
/// The run directory of `peha run`: out/<run>/ with the copy of the config it ran with (its origin,
/// where its relative paths resolve, and the seed used), and out/latest pointing at the last run.

#include <cstdint>
#include <filesystem>
#include <string>

namespace peha::app {

/// <config stem>-<UTC time stamp>, e.g. e1_one_dof-20250101-120000.
std::string default_run_name(const std::filesystem::path& config);

class RunDir {
 public:
  /// `name` empty: default_run_name(config), taken when the directory is created.
  RunDir(std::filesystem::path config, std::filesystem::path out_root, std::string name);

  /// Creates out_root/<name>/ and writes config.yaml (the config's text after a header naming its
  /// origin and `seed`). Call it once everything is loaded and checked; returns the directory.
  std::filesystem::path create(std::uint64_t seed);
  bool created() const noexcept { return !dir_.empty(); }
  const std::filesystem::path& path() const noexcept { return dir_; }

  /// Points out_root/latest at the run directory (best effort; after the run ended).
  void link_latest() const;

 private:
  std::filesystem::path config_, out_root_;
  std::string name_;
  std::filesystem::path dir_;
};

}  // namespace peha::app
