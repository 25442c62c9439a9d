#include "peha/hardware/replay_backend.hpp"
#include "peha/io/backend.hpp"

#include "peha/runtime/csv_log.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace peha::hardware {
namespace {

using io::kNaN;

}  // namespace

std::array<double, kSensorColumns.size()> sensor_columns(const io::JointSensors& s) noexcept {
  return {s.angle_rad,
          s.agonist_loadcell_N,
          s.antagonist_loadcell_N,
          s.agonist_pressure_Pa * 1e-6,
          s.antagonist_pressure_Pa * 1e-6,
          s.supply_pressure_Pa * 1e-6,
          s.redundant_angle_rad,
          s.motor_torque_Nm};
}

std::array<double, kCommandColumns.size()> command_columns(const io::JointCommand& c) noexcept {
  return {c.agonist_pressure_Pa * 1e-6, c.antagonist_pressure_Pa * 1e-6, c.motor_torque_Nm};
}

ReplayBackend::ReplayBackend(const std::filesystem::path& log, const std::vector<std::string>& joint_names,
                             const std::vector<std::string>& prefixes, double period_s)
    : info_{"replay:" + log.string(), joint_names, period_s},
      log_(log),
      prefixes_(prefixes.empty() ? std::vector<std::string>(joint_names.size()) : prefixes),
      gate_(period_s, sim::kSafeVent_s) {
  if (prefixes_.size() != joint_names.size()) throw std::invalid_argument("ReplayBackend: one column prefix per joint");
  if (joint_names.size() > static_cast<std::size_t>(io::kMaxJoints)) throw std::invalid_argument("ReplayBackend: too many joints");
  std::vector<std::string> names = {"t_s"};
  for (const std::string& p : prefixes_) {
    for (const char* c : kSensorColumns) names.push_back(p + c);
    for (const char* c : kCommandColumns) names.push_back(p + c);
  }
  const std::vector<std::vector<double>> cols = runtime::read_csv_log_columns(log, names);
  std::string missing;
  constexpr std::size_t kPerJoint = kSensorColumns.size() + kCommandColumns.size();
  for (std::size_t j = 0; j < prefixes_.size(); ++j) {
    for (std::size_t c = 0; c < kRequiredSensorColumns; ++c) {
      if (cols[1 + j * kPerJoint + c].empty()) missing += (missing.empty() ? "" : ", ") + names[1 + j * kPerJoint + c];
    }
  }
  if (cols[0].empty() && missing.empty()) throw std::runtime_error(fmt::format("replay: {}: the log has no rows (or no t_s column)", log.string()));
  if (!missing.empty()) {
    throw std::runtime_error(fmt::format("replay: {}: the log lacks the sensor column(s) {} (a replay feeds the controller what the "
                                         "sensors measured: angle, both load cells, both pressures per joint)",
                                         log.string(), missing));
  }
  t_s_ = cols[0];
  const std::size_t n = t_s_.size();
  for (std::size_t i = 1; i < n; ++i) {
    const double step = t_s_[i] - t_s_[i - 1];
    // A board run logs only fresh samples: a missed reply leaves a gap of whole periods.
    const double periods = std::round(step / period_s);
    if (!(periods >= 1.0) || std::abs(step - periods * period_s) > 0.01 * period_s) {
      throw std::runtime_error(fmt::format("replay: {}: row {}: t_s steps by {} s; the scenario's control period is {} s (a replay feeds one "
                                           "row per cycle of the same rate)",
                                           log.string(), i + 1, step, period_s));
    }
  }
  const std::size_t joints = joint_names.size();
  samples_.resize(n);
  recorded_.assign(n * joints * kCommands, kNaN);
  replayed_.assign(n * joints * kCommands, kNaN);
  auto value = [&](std::size_t column, std::size_t row) { return cols[column].empty() ? kNaN : cols[column][row]; };
  for (std::size_t r = 0; r < n; ++r) {
    io::SensorState& s = samples_[r];
    s.time_s = t_s_[r];
    s.sequence = r + 1;
    s.joint_count = static_cast<int>(joints);
    for (std::size_t j = 0; j < joints; ++j) {
      const std::size_t base = 1 + j * kPerJoint;
      io::JointSensors& js = s.joints[j];  // kSensorColumns' order
      js.angle_rad = value(base + 0, r);
      js.agonist_loadcell_N = value(base + 1, r);
      js.antagonist_loadcell_N = value(base + 2, r);
      js.agonist_pressure_Pa = value(base + 3, r) * 1e6;
      js.antagonist_pressure_Pa = value(base + 4, r) * 1e6;
      js.supply_pressure_Pa = value(base + 5, r) * 1e6;
      js.redundant_angle_rad = value(base + 6, r);
      js.motor_torque_Nm = value(base + 7, r);
      for (int c = 0; c < kCommands; ++c) {
        recorded_[(r * joints + j) * kCommands + static_cast<std::size_t>(c)] = value(base + kSensorColumns.size() + static_cast<std::size_t>(c), r);
      }
    }
  }
}

bool ReplayBackend::read(io::SensorState& state) noexcept {
  if (next_ >= samples_.size()) return false;
  io::copy_used(state, samples_[next_]);
  have_row_ = true;
  return true;
}

bool ReplayBackend::write(const io::Command& command) noexcept {
  const io::Command& applied = gate_.apply(command);
  if (!have_row_) return true;  // a held cycle after the last row: nothing to answer
  const std::size_t joints = info_.joint_names.size();
  for (std::size_t j = 0; j < joints && j < static_cast<std::size_t>(applied.joint_count); ++j) {
    const std::array<double, kCommandColumns.size()> sent = command_columns(applied.joints[j]);
    std::copy(sent.begin(), sent.end(), replayed_.begin() + static_cast<std::ptrdiff_t>((next_ * joints + j) * kCommands));
  }
  have_row_ = false;
  ++next_;
  return true;
}

ReplayBackend::Difference ReplayBackend::max_difference() const noexcept {
  Difference d{kNaN, kNaN};
  const std::size_t per_row = info_.joint_names.size() * kCommands;
  for (std::size_t i = 0; i < next_ * per_row; ++i) {
    const double e = std::abs(replayed_[i] - recorded_[i]);
    if (!std::isfinite(e)) continue;
    double& into = (i % kCommands == 2) ? d.motor_Nm : d.pressure_MPa;
    into = std::isnan(into) ? e : std::max(into, e);
  }
  return d;
}

void ReplayBackend::write_commands(const std::filesystem::path& path, const std::vector<std::string>& comments) const {
  std::vector<std::string> columns = {"t_s"};
  for (const std::string& p : prefixes_) {
    for (const char* c : kCommandColumns) {
      columns.push_back("recorded_" + p + c);
      columns.push_back("replayed_" + p + c);
    }
  }
  runtime::CsvLog out(columns, next_);
  const std::size_t per_row = info_.joint_names.size() * kCommands;
  for (std::size_t r = 0; r < next_; ++r) {
    out.begin_row();
    out.set(0, t_s_[r]);
    for (std::size_t i = 0; i < per_row; ++i) {
      out.set(1 + 2 * i, recorded_[r * per_row + i]);
      out.set(2 + 2 * i, replayed_[r * per_row + i]);
    }
  }
  out.write(path, comments);
}

}  // namespace peha::hardware
