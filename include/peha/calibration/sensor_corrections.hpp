#pragma once
/// \file
/// The load-cell corrections the rig's sensor check finds (`peha check-sensors`, docs/calibration.md
/// "Sensor check") and an E1 scenario loads (`controller.sensor_corrections: FILE`): per cell its
/// vented zero and its effective gain (its own gain x the controller's pulley radius / the rig's).
/// The reader is strict: unknown keys, a gain outside kMinLoadcellGain..kMaxLoadcellGain or a zero
/// beyond what the tare believes are refused with file:line.

#include "peha/config/reader.hpp"

#include <filesystem>
#include <string>

namespace peha::calibration {

/// An effective gain outside this band is a wrong channel map, a damaged cell or a wrong known mass,
/// not something to correct in software.
inline constexpr double kMinLoadcellGain = 0.8;
inline constexpr double kMaxLoadcellGain = 1.2;

struct SensorCorrections {
  double loadcell_zero_N[2] = {0, 0};  ///< agonist, antagonist: the reading with the muscle vented, N
  double loadcell_gain[2] = {1, 1};    ///< agonist, antagonist: reading / (force x r_rig / r_controller)
  std::string source;                  ///< what produced it (command, scenario, known mass)
};

/// Reads a corrections file; a zero beyond +-max_zero_N (the scenario's loadcell_check.max_tare_N)
/// or a gain outside kMinLoadcellGain..kMaxLoadcellGain is refused (config::Error, file:line).
SensorCorrections read_sensor_corrections(const config::Document& doc, double max_zero_N);
/// Writes `c` to `path` atomically (a comment header, then the keys read_sensor_corrections reads).
void write_sensor_corrections(const std::filesystem::path& path, const SensorCorrections& c);

}  // namespace peha::calibration
