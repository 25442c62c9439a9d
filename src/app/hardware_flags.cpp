#include "peha/app/hardware_flags.hpp"

#include "peha/app/cli_checks.hpp"

#include <fmt/format.h>

namespace peha::app {

void add_hardware_flags(CLI::App& cmd, HardwareFlags& flags, const std::string& what) {
  cmd.add_option("--backend", flags.backend,
                 "The hardware (docs/runtime.md, 'One hardware door'): sim: (the default) " + what +
                     ";\nudp://A.B.C.D:PORT the multifunction board (or 'peha mfb-emulator'; several boards: one address per board,\n"
                     "comma-separated), in real time; needs the config's mfb: section");
  cmd.add_option("--rt-priority", flags.fifo_priority, "With --backend udp://: SCHED_FIFO priority of the loop (0 = don't ask)")
      ->capture_default_str()->check(signed_integer())->check(CLI::Range(0, 99));
  cmd.add_option("--cpu", flags.cpu, "With --backend udp://: pin the loop to this CPU (-1 = don't)")->check(signed_integer())->capture_default_str();
  cmd.add_option("--recover-after", flags.recover_after_s,
                 "With --backend udp://: the operator's recover command this many s after a fault (unattended runs);\n"
                 "without it, type r + Enter on the terminal to recover")
      ->check(decimal())->check(CLI::Range(0.0, 3600.0));
}

experiments::RunRequest hardware_request(const HardwareFlags& flags, const std::filesystem::path& config) {
  experiments::RunRequest r;
  r.config = config;
  r.backend = flags.backend;
  r.fifo_priority = flags.fifo_priority;
  r.cpu = flags.cpu;
  r.recover_after_s = flags.recover_after_s;
  return r;
}

std::optional<experiments::HardwareRunOptions> procedure_hardware(const HardwareFlags& flags, const std::filesystem::path& config,
                                                                  const std::optional<mfb::LinkConfig>& link, const char* why_no_replay,
                                                                  const std::filesystem::path& out) {
  std::optional<experiments::HardwareRunOptions> hw = experiments::realtime_options(hardware_request(flags, config));
  if (!hw) return std::nullopt;
  if (hw->backend.kind == hardware::BackendKind::kReplay) {
    fmt::print(stderr, "error: --backend {}: {}, and a replayed log answers no command: run it on sim: or udp://\n", hw->backend.text,
               why_no_replay);
    return std::nullopt;
  }
  if (hw->backend.kind != hardware::BackendKind::kBoards) return hw;
  if (!link) {
    fmt::print(stderr, "config error: {}: --backend {} needs an mfb: section (channel map, watchdogs)\n", config.string(), hw->backend.text);
    return std::nullopt;
  }
  if (!experiments::check_board_addresses(config.string(), *link, *hw)) return std::nullopt;
  hw->dir = out.parent_path().empty() ? std::filesystem::path(".") : out.parent_path();
  std::filesystem::create_directories(hw->dir);
  return hw;
}

}  // namespace peha::app
