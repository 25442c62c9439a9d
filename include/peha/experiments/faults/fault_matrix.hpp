#pragma once
/// \file
/// The fault matrix (`peha faults`, docs/safety.md): every fault the simulated plant can inject, at
/// several moments of E1 (holding still, during a push, just after a release), in process, with the
/// supervisor's plausibility stage on. Per row: which flag detected it and how many control cycles
/// after the fault, the safe state taken, and what the plant did after the fault (peak muscle force,
/// peak joint speed, lowest wire tension, limits exceeded) - plus a nominal row without a fault.

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/sim/plant_faults.hpp"

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

struct FaultMoment {
  std::string name;   ///< "holding", "push", "after_release"
  double time_s = 0;  ///< when the fault starts
};

/// The E1 moments the matrix injects at: 4 s (at rest after the start-up hold), the middle of the
/// first push's move, and 0.5 s after that push lets go.
std::vector<FaultMoment> e1_fault_moments(const E1Scenario& scenario);

struct FaultRow {
  std::string fault;         ///< kind name, or "none"
  std::string target;        ///< "joint.agonist", "joint", ...
  std::string moment;
  double fault_time_s = 0;
  bool detected = false;
  std::string flag;          ///< the first latched flag ("-" when none)
  double detection_cycles = 0;  ///< control cycles from the fault to the first latched flag (NaN: none)
  std::string safe_state;    ///< hold / descend / vent ("-" when none)
  double rest_after_s = 0;   ///< from detection until the joint stays below 5 deg/s for 0.5 s (NaN: never)
  double peak_force_N = 0;   ///< either muscle after the fault (plant truth)
  double peak_speed_degps = 0;  ///< |joint speed| after the fault (plant truth)
  double min_tension_N = 0;  ///< lowest wire tension after the fault (plant truth)
  int limits_exceeded = 0;   ///< failed envelope checks: force ceilings, pressure, motor rating, joint range
  /// Why no safe state can keep this fault within the limits (a limit was exceeded and the kind is one
  /// physics_forbids names); empty otherwise - then an exceeded limit is a miss of the designed outcome.
  std::string physics_forbids;
  bool log_complete = false; ///< one log row per control cycle to the end
  bool passed = false;       ///< the run's verdict (a faulted run never passes)
};

struct FaultMatrixOptions {
  std::string case_name;         ///< E1 case (default: the first)
  double after_fault_s = 5.0;    ///< each run ends this long after its fault
  std::vector<sim::FaultKind> kinds;  ///< default: every kind
  std::vector<std::string> moments;   ///< default: every moment
};

/// The reason no safe state can avoid a limit after fault `kind` (a wire break, a valve stuck open,
/// the e-stop), or empty when a designed safe state must avoid every limit.
std::string physics_forbids(sim::FaultKind kind);

/// Runs the matrix (the nominal row first). The scenario is run with the plausibility stage on
/// (limits.monitor.enabled) and its start-up tare as configured. `progress` (optional) gets each row as it finishes.
std::vector<FaultRow> run_fault_matrix(E1Scenario scenario, const FaultMatrixOptions& options,
                                       const std::function<void(const FaultRow&)>& progress = {});

/// faults.md (table + summary) and faults.csv in `dir`.
void write_fault_matrix(const std::filesystem::path& dir, const std::vector<FaultRow>& rows, const std::string& scenario_name);

}  // namespace peha::experiments
