#pragma once
/// \file
/// The command-line door to the hardware for a procedure (`peha record-calibration`, `peha
/// identify-gravity`): --backend and the real-time options, as `peha run` takes them.

#include "peha/app/commands.hpp"
#include "peha/experiments/run_request.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace peha::app {

/// Adds --backend, --rt-priority, --cpu and --recover-after to `cmd`, filling `flags`. `what`
/// names the procedure's plant in --backend's help ("the simulated rig").
void add_hardware_flags(CLI::App& cmd, HardwareFlags& flags, const std::string& what);

/// The request experiments::realtime_options reads, from the flags (the scenario `config` for the logs).
experiments::RunRequest hardware_request(const HardwareFlags& flags, const std::filesystem::path& config);

}  // namespace peha::app
