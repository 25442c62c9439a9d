#include "peha/calibration/sensor_corrections.hpp"

#include "peha/config/atomic_file.hpp"

#include <fmt/format.h>

#include <ostream>

namespace peha::calibration {

namespace {
constexpr const char* kMuscles[2] = {"agonist", "antagonist"};
}

SensorCorrections read_sensor_corrections(const config::Document& doc, double max_zero_N) {
  config::Map root = doc.root();
  SensorCorrections c;
  c.source = root.string("source");
  for (int i = 0; i < 2; ++i) {
    config::Map m = root.map(kMuscles[i]);
    c.loadcell_zero_N[i] = m.number("loadcell_zero_N", {-max_zero_N, max_zero_N});
    c.loadcell_gain[i] = m.number("loadcell_gain", {kMinLoadcellGain, kMaxLoadcellGain});
    m.finish();
  }
  root.finish();
  return c;
}

void write_sensor_corrections(const std::filesystem::path& path, const SensorCorrections& c) {
  config::write_file_atomically(path, [&](std::ostream& out) {
    out << "# Load-cell corrections of the one-DOF rig (peha check-sensors; docs/calibration.md \"Sensor check\").\n"
           "# The controller uses (reading - loadcell_zero_N) / loadcell_gain; loadcell_gain is the cell's own gain\n"
           "# x the controller's pulley radius / the rig's (for torque only their product matters).\n";
    out << fmt::format("source: \"{}\"\n", c.source);
    for (int i = 0; i < 2; ++i) {
      out << fmt::format("{}: {{loadcell_zero_N: {:.4f}, loadcell_gain: {:.6f}}}\n", kMuscles[i], c.loadcell_zero_N[i], c.loadcell_gain[i]);
    }
  });
}

}  // namespace peha::calibration
