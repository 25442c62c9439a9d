#pragma once
/// \file
/// The run directory of `peha run` (and robustness, faults): out/<run>/ with the copy of the config
/// it ran with (its origin, where its relative paths resolve, and the seed used), and out/latest
/// pointing at the last completed run.
///
/// A run is written into a temporary folder beside its final place, `out/.<run>.partial-<pid>/`,
/// and renamed into place only by commit(): a run that fails or is killed never touches an earlier
/// run of the same name (the earlier one is swapped out atomically, then removed, only when the new
/// one is complete), and `latest` moves only on commit. A failed run's files stay in the partial
/// folder for the post-mortem.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace peha::app {

/// <config stem>-<UTC time stamp>, e.g. e1_one_dof-20250101-120000.
std::string default_run_name(const std::filesystem::path& config);

class RunDir {
 public:
  /// `name` empty: default_run_name(config), taken now. Throws UsageError (exit 2, nothing written)
  /// when the name is not one folder name, `out_root` or out_root/<name> exists and is not a folder,
  /// or out_root/<name> holds one of `inputs` (the config and what it names: committing the run
  /// would replace them).
  RunDir(std::filesystem::path config, std::filesystem::path out_root, std::string name,
         const std::vector<std::filesystem::path>& inputs = {});

  /// Creates the partial folder and writes config.yaml into it (the config's text after a header
  /// naming its origin and `seed`). Call it once everything is loaded and checked; returns the
  /// folder the run writes into (the partial one until commit()).
  std::filesystem::path create(std::uint64_t seed);
  bool created() const noexcept { return !dir_.empty(); }
  const std::filesystem::path& path() const noexcept { return dir_; }
  /// out_root/<name>: where the run is after commit().
  std::filesystem::path final_path() const { return out_root_ / name_; }

  /// Puts the complete run in place (an earlier run of the name is exchanged atomically and then
  /// removed) and points out_root/latest at it. path() is the final folder afterwards.
  void commit();
  bool committed() const noexcept { return committed_; }

  /// Not committed: says where the partial run's files are and that the earlier run is untouched.
  ~RunDir();

 private:
  std::filesystem::path config_, out_root_;
  std::string name_;
  std::filesystem::path dir_;
  bool committed_ = false;
};

}  // namespace peha::app
