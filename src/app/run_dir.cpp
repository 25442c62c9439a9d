#include "peha/app/run_dir.hpp"

#include "peha/app/cli_checks.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <stdexcept>

namespace peha::app {

std::string default_run_name(const std::filesystem::path& config) {
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  return fmt::format("{}-{:%Y%m%d-%H%M%S}", config.stem().string(), now);
}

RunDir::RunDir(std::filesystem::path config, std::filesystem::path out_root, std::string name)
    : config_(std::move(config)), out_root_(std::move(out_root)), name_(std::move(name)) {}

std::filesystem::path RunDir::create(std::uint64_t seed) {
  if (created()) throw std::logic_error("the run directory is created once");
  if (name_.empty()) name_ = default_run_name(config_);
  std::string check = name_;
  if (const std::string why = run_name()(check); !why.empty()) throw UsageError("--name: " + why);
  const std::filesystem::path dir = out_root_ / name_;
  std::filesystem::create_directories(dir);
  std::ifstream in(config_);
  std::ofstream out(dir / "config.yaml");
  out << fmt::format("# peha run copy of {}\n# relative paths resolve against {}\n# seed used: {}\n",
                     std::filesystem::absolute(config_).string(), std::filesystem::absolute(config_).parent_path().string(), seed)
      << in.rdbuf();
  dir_ = dir;
  return dir_;
}

void RunDir::link_latest() const {
  std::error_code ec;
  std::filesystem::remove(out_root_ / "latest", ec);
  std::filesystem::create_directory_symlink(name_, out_root_ / "latest", ec);
}

}  // namespace peha::app
