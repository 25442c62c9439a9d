#pragma once
/// \file
/// The command-line door to the hardware for a procedure (`peha record-calibration`, `peha
/// identify-gravity`): --backend and the real-time options, as `peha run` takes them.

#include "peha/app/commands.hpp"
#include "peha/experiments/run_request.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace peha::app {

/// Adds --backend, --rt-priority, --cpu and --recover-after to `cmd`, filling `flags`. `what`
/// names the procedure's plant in --backend's help ("the simulated rig").
void add_hardware_flags(CLI::App& cmd, HardwareFlags& flags, const std::string& what);

/// The request experiments::realtime_options reads, from the flags (the scenario `config` for the logs).
experiments::RunRequest hardware_request(const HardwareFlags& flags, const std::filesystem::path& config);

/// A procedure's hardware (record-calibration, identify-gravity): sim: or boards, checked before
/// anything runs; nullopt after a message (exit code 2): a malformed --backend, a replay (`why_no_replay`:
/// what the procedure needs that a log cannot give), boards without the scenario's mfb: section or
/// with the wrong number of addresses. On boards `dir` is made the folder of `out` (created), where
/// the run's per-cycle log and timing go.
std::optional<experiments::HardwareRunOptions> procedure_hardware(const HardwareFlags& flags, const std::filesystem::path& config,
                                                                  const std::optional<mfb::LinkConfig>& link, const char* why_no_replay,
                                                                  const std::filesystem::path& out);

}  // namespace peha::app
