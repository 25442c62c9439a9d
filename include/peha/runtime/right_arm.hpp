#pragma once
/// \file
/// Experiments on the simulated right arm (SPEC §7): E3 "postures" - the operator moves the arm with
/// its mannequin to several postures and lets go; with gravity compensation tau = J^T G and no
/// position feedback it should stay. The scenario is configs/right_arm.yaml.

#include "peha/config/reader.hpp"
#include "peha/control/arm_controller.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/limits.hpp"
#include "peha/sim/right_arm.hpp"

#include <string>
#include <vector>

namespace peha::runtime {

struct ArmPosture {
  std::string name;
  double sfe_rad = 0;
  double efe_rad = 0;
};

struct ArmScenario {
  std::string description;
  std::uint64_t seed = 1;
  double period_s = 1e-3;
  control::ArmControllerModel controller;
  safety::LimitsModel limits;
  sim::RightArmPlantParams plant;
  double move_s = 2.5, hold_s = 1.0, observe_s = 10.0;
  std::vector<ArmPosture> postures;
};

/// Reads configs/right_arm.yaml (and the body file it names); throws config::Error.
ArmScenario read_arm_scenario(const config::Document& doc);

struct PostureResult {
  std::string name;
  double target_deg[2] = {0, 0};      ///< SFE, EFE the operator aimed at
  double released_deg[2] = {0, 0};    ///< where the arm was at release (plant truth)
  double drift_deg[2] = {0, 0};       ///< angle observe_s after release minus at release
  double max_excursion_deg[2] = {0, 0};
};

struct PosturesResult {
  std::vector<PostureResult> postures;
  double peak_muscle_force_N = 0;     ///< any muscle, plant truth
  double min_wire_tension_N = 0;      ///< any wire, plant truth
  double peak_operator_torque_Nm = 0;
  double realtime_factor = 0;
  bool within_limits = false;         ///< every force/tension/pressure/motor limit held
};

const std::vector<std::string>& arm_log_columns();

/// E3. `log` (optional) gets one row per control cycle.
PosturesResult run_postures(const ArmScenario& scenario, CsvLog* log);

}  // namespace peha::runtime
