#pragma once
/// \file
/// A recorded run as hardware (`--backend replay:<log.csv>`): each read() gives the next row of the
/// log's sensor columns, each write() keeps the command the controller sent for that row beside the
/// one the log recorded. For regression tests (a log replayed into the same controller gives its
/// commands back) and for offline analysis of hardware logs (a new controller against what a real
/// rig measured). The plant does not answer the new commands: a replay shows what a controller
/// would have commanded on the recorded sensors, not what the arm would have done.
///
/// Columns, per joint with the joint's column prefix (e.g. "" for the one-DOF rig's logs, "sfe_"
/// for an arm's): the sensors kSensorColumns (the first kRequiredSensorColumns required, the others
/// NaN when absent: not measured); recorded commands (optional) kCommandColumns. Time `t_s`.
/// read()/write()/status() are noexcept and allocation-free (every row is loaded at construction).

#include "peha/io/backend.hpp"
#include "peha/sim/output_gate.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace peha::hardware {

/// Every io::JointSensors field as a log column (after the joint's prefix), in SI-derived units: what
/// a log must record of each joint, from what the controller read, for its run to be replayed.
inline constexpr std::array<const char*, 8> kSensorColumns = {
    "angle_rad",           "agonist_loadcell_N",  "antagonist_loadcell_N", "agonist_pressure_MPa", "antagonist_pressure_MPa",
    "supply_pressure_MPa", "redundant_angle_rad", "motor_torque_monitor_Nm"};
/// The first kRequiredSensorColumns of kSensorColumns every joint needs (the rest are sensors a rig may lack).
inline constexpr std::size_t kRequiredSensorColumns = 5;
/// The commands a log records per joint (after its prefix), compared with what the replay's controller sends.
inline constexpr std::array<const char*, 3> kCommandColumns = {"agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa", "tau_motor_cmd_Nm"};

/// A joint's sample as kSensorColumns' values (pressures in MPa): what a log writes for a replay to read back.
std::array<double, kSensorColumns.size()> sensor_columns(const io::JointSensors& s) noexcept;
/// A joint's command as kCommandColumns' values (pressures in MPa).
std::array<double, kCommandColumns.size()> command_columns(const io::JointCommand& c) noexcept;

class ReplayBackend final : public io::Backend {
 public:
  /// Loads `log` for the io joints `joint_names` (column prefix `prefixes[j]`; empty: "" for each).
  /// Throws std::runtime_error naming the file and every missing required column, a log without
  /// rows, or a time column whose step is not `period_s` (within 1 %).
  ReplayBackend(const std::filesystem::path& log, const std::vector<std::string>& joint_names, const std::vector<std::string>& prefixes,
                double period_s);

  const io::BackendInfo& info() const override { return info_; }
  void activate() noexcept override { gate_.activate(); }
  void deactivate() noexcept override { gate_.deactivate(); }
  void estop() noexcept override { gate_.estop(); }
  /// Never silent (the log is its own clock): last_sample_ns 0.
  io::BackendStatus status() const noexcept override { return gate_.status(); }
  /// The next row; false once every row was given.
  bool read(io::SensorState& state) noexcept override;
  /// Keeps the command (what the outputs would have got: the safe command while not active).
  bool write(const io::Command& command) noexcept override;

  const std::filesystem::path& log() const noexcept { return log_; }  ///< the recorded log
  std::size_t rows() const noexcept { return t_s_.size(); }
  double duration_s() const noexcept { return t_s_.back() - t_s_.front(); }
  /// Rows whose command was written (at most rows()).
  std::size_t replayed() const noexcept { return next_; }

  /// The largest |replayed - recorded| over the replayed rows, per command kind: muscle pressure
  /// (MPa) and motor torque (Nm); NaN where the log recorded no command of that kind.
  struct Difference {
    double pressure_MPa = 0;
    double motor_Nm = 0;
  };
  Difference max_difference() const noexcept;
  /// Writes `t_s` and, per joint and command, `recorded_<prefix><cmd>` beside `replayed_<prefix><cmd>`.
  void write_commands(const std::filesystem::path& path, const std::vector<std::string>& comments) const;

 private:
  static constexpr int kCommands = static_cast<int>(kCommandColumns.size());  ///< agonist, antagonist pressure (MPa), motor torque (Nm)
  io::BackendInfo info_;
  std::filesystem::path log_;
  std::vector<std::string> prefixes_;
  sim::OutputGate gate_;
  std::vector<double> t_s_;
  std::vector<io::SensorState> samples_;
  /// [row][joint * kCommands + c]: recorded, then what the controller sent for the row.
  std::vector<double> recorded_, replayed_;
  std::size_t next_ = 0;  ///< rows answered by a write (the next row read() gives)
  bool have_row_ = false;  ///< read() gave a row that write() has not answered yet
};

}  // namespace peha::hardware
