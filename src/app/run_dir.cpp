#include "peha/app/run_dir.hpp"

#include "peha/app/cli_checks.hpp"
#include "peha/config/atomic_file.hpp"
#include "peha/config/input_file.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <fcntl.h>
#include <stdexcept>
#include <unistd.h>

namespace peha::app {
namespace {

/// True when `inner` is `outer` or lies inside it (both resolved; neither need exist).
bool inside(const std::filesystem::path& inner, const std::filesystem::path& outer) {
  std::error_code ec;
  const std::filesystem::path i = std::filesystem::weakly_canonical(inner, ec), o = std::filesystem::weakly_canonical(outer, ec);
  auto oi = o.begin(), ii = i.begin();
  for (; oi != o.end(); ++oi, ++ii) {
    if (oi->empty() && std::next(oi) == o.end()) break;  // a trailing separator
    if (ii == i.end() || *ii != *oi) return false;
  }
  return true;
}

}  // namespace

std::string default_run_name(const std::filesystem::path& config) {
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  return fmt::format("{}-{:%Y%m%d-%H%M%S}", config.stem().string(), now);
}

RunDir::RunDir(std::filesystem::path config, std::filesystem::path out_root, std::string name,
               const std::vector<std::filesystem::path>& inputs)
    : config_(std::move(config)), out_root_(std::move(out_root)), name_(std::move(name)) {
  if (name_.empty()) name_ = default_run_name(config_);
  std::string check = name_;
  if (const std::string why = run_name()(check); !why.empty()) throw UsageError("--name: " + why);
  std::error_code ec;
  if (std::filesystem::exists(out_root_, ec) && !std::filesystem::is_directory(out_root_, ec)) {
    throw UsageError(fmt::format("--out {} is not a folder (a file, pipe or device): runs are written into a folder", out_root_.string()));
  }
  const std::filesystem::path final = final_path();
  if (std::filesystem::exists(std::filesystem::symlink_status(final, ec)) && !std::filesystem::is_directory(std::filesystem::symlink_status(final, ec))) {
    throw UsageError(fmt::format("--out/--name: {} exists and is not a run folder (a file, link, pipe or device): refusing to replace it; "
                                 "choose another --name", final.string()));
  }
  std::vector<std::filesystem::path> all = inputs;
  all.push_back(config_);
  for (const std::filesystem::path& in : all) {
    if (!in.empty() && inside(in, final)) {
      throw UsageError(fmt::format("--out/--name: the run folder {} holds {}, which this run reads: the finished run would replace "
                                   "it; choose another --name or --out", final.string(), in.string()));
    }
  }
}

std::filesystem::path RunDir::create(std::uint64_t seed) {
  if (created()) throw std::logic_error("the run directory is created once");
  const std::string text = config::read_input_file(config_, config::InputKind::kConfig);
  std::filesystem::create_directories(out_root_);
  const std::filesystem::path dir = out_root_ / fmt::format(".{}.partial-{}", name_, ::getpid());
  std::filesystem::remove_all(dir);  // a partial folder of an earlier process with this pid
  std::filesystem::create_directory(dir);
  config::write_file_atomically(dir / "config.yaml", [&](std::ostream& out) {
    out << fmt::format("# peha run copy of {}\n# relative paths resolve against {}\n# seed used: {}\n",
                       std::filesystem::absolute(config_).string(), std::filesystem::absolute(config_).parent_path().string(), seed)
        << text;
  });
  dir_ = dir;
  return dir_;
}

void RunDir::commit() {
  if (!created() || committed_) throw std::logic_error("commit a created run directory once");
  const std::filesystem::path final = final_path();
  std::error_code ec;
  if (std::filesystem::exists(std::filesystem::symlink_status(final, ec))) {
    // Swap the complete run with the earlier one in one step: at no moment is there no run of the name.
    if (::renameat2(AT_FDCWD, dir_.c_str(), AT_FDCWD, final.c_str(), RENAME_EXCHANGE) != 0) {
      throw std::runtime_error(fmt::format("{}: cannot put the run in place of the earlier one: {}; the new run is in {}", final.string(),
                                           std::strerror(errno), dir_.string()));
    }
    std::filesystem::remove_all(dir_, ec);  // now the earlier run
  } else {
    std::filesystem::rename(dir_, final);
  }
  dir_ = final;
  committed_ = true;
  // `latest` is replaced only when it is a link (a folder or file of that name is the user's).
  const std::filesystem::path latest = out_root_ / "latest";
  const std::filesystem::file_status st = std::filesystem::symlink_status(latest, ec);
  if (std::filesystem::exists(st) && !std::filesystem::is_symlink(st)) return;
  const std::filesystem::path tmp = out_root_ / fmt::format(".latest.tmp-{}", ::getpid());
  std::filesystem::remove(tmp, ec);
  std::filesystem::create_directory_symlink(name_, tmp, ec);
  if (!ec) std::filesystem::rename(tmp, latest, ec);
  if (ec) std::filesystem::remove(tmp, ec);
}

RunDir::~RunDir() {
  if (created() && !committed_) {
    std::fprintf(stderr, "the run did not complete: its files are in %s; %s is untouched\n", dir_.c_str(), final_path().c_str());
  }
}

}  // namespace peha::app
