#pragma once
/// \file
/// The one door every input file of peha comes through: configs, calibration files and CSVs, the
/// goniometer's CSV, key files, logs for replay. It opens the path without blocking (a FIFO with no
/// writer would hang an ifstream), refuses anything that is not a regular file (a device, a pipe, a
/// folder) and anything larger than the limit of its kind, and returns the bytes it read, so the
/// checks and the parse see the same bytes. Outputs never come through here.

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace peha::config {

/// What an input file is, which fixes the largest size accepted. The limits are far above what peha
/// writes (a 108 s calibration recording is 2 MB, E1's whole log 2.4 MB, a config 20 kB): a file
/// beyond them is the wrong file, or /dev/zero through a link.
enum class InputKind {
  kConfig,          ///< YAML: scenario, channel map, model, calibration file: 256 MiB (reader.hpp kMaxFileBytes)
  kCalibrationCsv,  ///< a calibration recording: 512 MiB (5 M rows, 83 min at 1 kHz)
  kCsv,             ///< other CSV data (the goniometer's recording): 64 MiB
  kLog,             ///< a run's CSV log, replayed or analysed: 1 GiB (an hour at 1 kHz with 60 columns)
  kKey,             ///< an MFB key file: 4 KiB (64 hex digits and comments)
};

/// The largest size accepted for `kind`, bytes.
std::size_t max_input_bytes(InputKind kind) noexcept;
/// What `kind` is called in messages ("config file", "calibration CSV", ...).
const char* input_kind_name(InputKind kind) noexcept;

/// An input file that cannot be read as one: missing, not a regular file, too large, unreadable.
/// The message names the file and what it is.
class InputFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The whole content of input file `path` of kind `kind`. Throws InputFileError (naming `path` and
/// what was expected vs found) when it does not exist, is not a regular file, or is larger than
/// max_input_bytes(kind) (checked on the open descriptor and again while reading: a file that grows
/// is caught too).
std::string read_input_file(const std::filesystem::path& path, InputKind kind);

}  // namespace peha::config
