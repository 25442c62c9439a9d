#pragma once
/// \file
/// Strict checks of command-line values (the same rules as the config reader) and of output paths.

#include <CLI/CLI.hpp>

#include <filesystem>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

namespace peha::app {

/// A plain decimal number ([+-]digits[.digits][e[+-]digits]; no hex, nan, inf, spaces). Attach it
/// before a CLI::Range: CLI11's own conversion reads 0x10 as 16 and lets nan through a range.
const CLI::Validator& decimal();
/// Digits only: no sign (CLI11 turns -1 into 2^64 - 1 for an unsigned option), no hex, no exponent.
const CLI::Validator& unsigned_integer();
/// [-]digits.
const CLI::Validator& signed_integer();
/// A run directory name: one path component of letters, digits and . _ + - (not starting with '.' or
/// '-'), at most 100 characters, so that the run stays inside the output root.
const CLI::Validator& run_name();

/// A command line that cannot be carried out as given (exit code 2, nothing written).
class UsageError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Throws UsageError (exit 2, before anything is written) when output file `out` may not be
/// written: it exists and is not a regular file (a FIFO, a device, a folder: writing would block,
/// feed a device or fail half way), or it is (resolves to) one of `inputs`: an output never
/// overwrites what the command reads.
void refuse_unsafe_output(const std::filesystem::path& out, const std::vector<std::filesystem::path>& inputs,
                          const char* option = "--out");

/// The files a scenario reads: `config`, every file it names (a string value that, resolved against
/// the config's folder, is an existing regular file: channel maps, key files, models, calibrations,
/// other scenarios), and those the YAML ones among them name, three levels deep.
std::vector<std::filesystem::path> scenario_inputs(const std::filesystem::path& config);

}  // namespace peha::app
