#pragma once
/// \file
/// Calibration data (SPEC §3): a CSV with a header row of named columns with units.
/// Required: `pressure_MPa`, `contraction`, `force_N`; optional: `t_s`, `angle_rad`,
/// `wire_velocity_mps`. The load-cell zero the recording subtracted is `loadcell_zero_N` in the
/// sidecar `<csv>.meta.json` (config/csv_sidecar.hpp) that write_dataset writes. Lines starting with
/// `#` are comments, as in older recordings and the Festo maps; the one `# loadcell_zero_N: <N>`
/// of an older recording carries the zero (in one place only: both is an error). Anything else is
/// an error that names the file, line and column. The reader also rejects data that cannot be a calibration: NaN/inf,
/// unit mistakes (pressure in kPa or Pa under a `pressure_MPa` header, contraction in percent,
/// negative pressures beyond noise), too few rows, no excitation. Nothing half-read is returned.

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace peha::calibration {

/// A data error, with file, line and column where they apply.
class DataError : public std::runtime_error {
 public:
  explicit DataError(const std::string& message) : std::runtime_error(message) {}
};

/// One muscle's calibration data, SI inside. Optional columns are empty when absent.
struct Dataset {
  std::vector<double> pressure_Pa;       ///< gauge pressure, Pa
  std::vector<double> contraction;       ///< rigid-wire contraction eps (from the joint angle), -
  std::vector<double> force_N;           ///< load-cell force at the muscle, N
  std::vector<double> t_s;               ///< time, s (empty if absent)
  std::vector<double> angle_rad;         ///< joint angle, rad (empty if absent)
  std::vector<double> wire_velocity_mps; ///< wire velocity, m/s (empty if absent)
  /// The load cell's reading with its muscle vented (zero force), N, which the recording has
  /// already subtracted from force_N (its start-up tare); 0 when no tare ran (or the file says
  /// nothing). On disk: `loadcell_zero_N` in the sidecar `<csv>.meta.json`, or an older recording's
  /// comment line `# loadcell_zero_N: <number>`.
  double loadcell_zero_N = 0.0;
  /// The muscle recorded, as `peha record-calibration --muscle` named it ("agonist"): `muscle` in
  /// the sidecar; empty when the file names none (a converted force map, an older recording).
  std::string muscle;
  std::string source;                    ///< file it came from
  std::string sha256;                    ///< hex SHA-256 of the file's bytes
  std::size_t size() const { return pressure_Pa.size(); }
};

/// Highest pressure a row may hold, MPa: above it the file is in kPa or Pa, not a reading (the
/// valves' supply is 0.8 MPa, Festo's muscles are rated to 0.6-0.8 MPa).
inline constexpr double kMaxPlausiblePressure_MPa = 1.2;

/// The force ceiling where no muscle is known, N: Festo's largest fluidic muscle (DMSP-40, 40 mm)
/// at kMaxPlausiblePressure_MPa, stretched 5 % (the far end of its datasheet map: 9331 N at
/// 0.62 MPa), scaled in proportion to the pressure (the muscle's force grows about linearly with
/// it). 18 060 N: no muscle a calibration CSV can come from pulls harder.
inline constexpr double kAnyMuscleMaxForce_N = 9331.0 / 0.62 * kMaxPlausiblePressure_MPa;

/// Limits the reader enforces.
struct DatasetRules {
  std::size_t min_rows = 50;
  double min_pressure_span_Pa = 0.05e6;  ///< max - min pressure must exceed this ("no excitation")
  double min_force_span_N = 20.0;        ///< max - min force must exceed this
  /// Highest force a row may hold, N: the muscle's own ceiling when it is known (the scenario's
  /// plant law: sim::force_ceiling_N), else any fluidic muscle's.
  double max_force_N = kAnyMuscleMaxForce_N;
  /// What max_force_N is, for the message that refuses a row above it.
  std::string max_force_reason = "the most any fluidic muscle pulls: Festo's largest, DMSP-40, at 1.2 MPa";
};

/// Reads and validates a calibration CSV; throws DataError naming file, line, column and reason.
Dataset read_dataset(const std::filesystem::path& path, const DatasetRules& rules = {});

/// The muscle a calibration CSV's sidecar names (Dataset::muscle), empty when it names none; throws
/// DataError if the sidecar is malformed.
std::string recorded_muscle(const std::filesystem::path& path);

/// Writes `data` as a calibration CSV (pressure in MPa), the header its first line, through a
/// temporary renamed into place; then `comments`, `loadcell_zero_N` and `muscle` (when named) to its sidecar
/// `<path>.meta.json`. Throws DataError naming the file.
void write_dataset(const std::filesystem::path& path, const Dataset& data, const std::vector<std::string>& comments);

/// Hex SHA-256 of a calibration CSV's bytes (read through config::read_input_file: a regular file
/// within the calibration CSV's size limit; DataError otherwise).
std::string sha256_file(const std::filesystem::path& path);

/// Hex SHA-256 of `bytes`.
std::string sha256_hex(std::string_view bytes);

}  // namespace peha::calibration
