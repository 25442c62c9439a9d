#pragma once
/// \file
/// The fault matrix (`peha faults`, docs/safety.md): every fault the simulated plant can inject, at
/// several moments of E1 (holding still, during a push, just after a release) or of E3 on the right
/// arm (holding a posture, while the operator moves the arm; faults on the elbow R_EFE), in process,
/// with the supervisor's plausibility stage on. Per row: which flag detected it and how many control
/// cycles after the fault, the safe state taken, and what the plant did after the fault (peak muscle
/// force, peak joint speed, lowest wire tension, limits exceeded; on the arm the worst of its actuated
/// joints) - plus a nominal row without a fault.

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/sim/plant_faults.hpp"

#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace peha::experiments {

struct FaultMoment {
  std::string name;   ///< E1: "holding", "push", "after_release"; E3: "holding", "moving"
  double time_s = 0;  ///< when the fault starts
};

/// The E1 moments the matrix injects at: 4 s (at rest after the start-up hold), the middle of the
/// first push's move, and 0.5 s after that push lets go.
std::vector<FaultMoment> e1_fault_moments(const E1Scenario& scenario);

/// The E3 moments: `holding` (1 s after the operator lets go of the first posture), `moving` (the
/// middle of the operator's move to the second posture) and, when a posture flexes the elbow by 45 deg
/// or more, `elbow_moving` (the middle of the operator's move into the first such posture: the
/// faulted elbow itself turning) and `elbow_flexed` (1 s after its release). Throws
/// std::invalid_argument when the scenario has fewer than two postures.
std::vector<FaultMoment> e3_fault_moments(const ArmScenario& scenario);

/// The moments of `all` that `wanted` names, in `all`'s order (all of them when `wanted` is empty).
/// Throws std::invalid_argument naming `experiment` and its moments for a name not among them.
std::vector<FaultMoment> select_fault_moments(std::vector<FaultMoment> all, const std::vector<std::string>& wanted,
                                              const char* experiment);

/// The arm's joint the E3 rows inject into (the elbow; supply faults and the e-stop hit the whole arm).
inline constexpr const char* kE3FaultJoint = "R_EFE";

struct FaultRow {
  std::string experiment;    ///< "E1" (one-DOF rig) or "E3" (right arm, postures)
  std::string fault;         ///< kind name, or "none"
  std::string target;        ///< "joint.agonist", "joint"; on the arm "R_EFE.agonist", "R_EFE", "arm" (every joint)
  std::string moment;
  double fault_time_s = 0;
  bool detected = false;
  std::string flag;          ///< the first latched flag ("-" when none)
  double detection_cycles = 0;  ///< control cycles from the fault to the first latched flag (NaN: none)
  /// Detection within this many cycles is prompt: 5, or the caught flag's own designed window when
  /// longer (loadcell_stuck: MonitorParams::loadcell_stuck_cycles equal readings).
  int prompt_cycles = 5;
  std::string safe_state;    ///< hold / descend / vent ("-" when none)
  double rest_after_s = 0;   ///< from detection until every joint stays below 5 deg/s for 0.5 s (NaN: never)
  double peak_force_N = 0;   ///< any muscle of any joint after the fault (plant truth)
  double peak_speed_degps = 0;  ///< |joint speed| of any joint after the fault (plant truth)
  double min_tension_N = 0;  ///< lowest wire tension of any joint after the fault (plant truth)
  /// The joints the three figures above come from (E1: "joint"; empty when no sample set them).
  std::string peak_force_joint, peak_speed_joint, min_tension_joint;
  int limits_exceeded = 0;   ///< failed envelope checks: force ceilings, pressure, motor rating, joint range
  /// Why no safe state can keep this fault within the limits (a limit was exceeded and the kind is one
  /// physics_forbids names); empty otherwise - then an exceeded limit is a miss of the designed outcome.
  std::string physics_forbids;
  /// An outage row (state_loss, board_reboot): from the fault to the operator's recovery re-arming the
  /// outputs (NaN: never re-armed, a miss). Its figures and range are judged from the first sample after
  /// the outage: the joint's speed within the monitor's max_joint_speed, never further out of its range
  /// than it lay when the samples came back (FaultMatrixOptions::recover_delay_s).
  double recovered_after_s = std::numeric_limits<double>::quiet_NaN();
  bool log_complete = false; ///< one log row per control cycle to the end (an outage's cycles have none)
  bool passed = false;       ///< the run's verdict (a faulted run never passes)
};

struct FaultMatrixOptions {
  std::string case_name;         ///< E1 case (default: the first); E3 has none
  double after_fault_s = 5.0;    ///< each run ends this long after its fault
  /// A slow fault's rows (a drifting load cell alone) end this long after it instead:
  /// 10 N/s takes seconds to become a force a check can tell from the model's error.
  double slow_after_fault_s = 20.0;
  /// An outage row's operator recovers this long after the samples come back (an unattended
  /// operator's recover_after_s: the outage's length plus this, from the fault).
  double recover_delay_s = 0.5;
  std::vector<sim::FaultKind> kinds;  ///< default: every kind
  std::vector<std::string> moments;   ///< default: every moment
};

/// How long the row of `fault` (a kind's name, or "a+b") runs after the fault: slow_after_fault_s
/// for a slow kind alone (loadcell_drift), after_fault_s otherwise (a pair: its fast member's); an
/// outage's row runs its length (the kind's default value) and recover_delay_s longer.
double row_after_fault_s(const FaultMatrixOptions& options, const std::string& fault);

/// The reason no safe state can avoid a limit after fault `kind` (a wire break, a valve stuck open,
/// the e-stop), or empty when a designed safe state must avoid every limit.
std::string physics_forbids(sim::FaultKind kind);
/// The double faults the matrix runs at every moment (both kinds wanted): a row "a+b" each.
const std::vector<std::pair<sim::FaultKind, sim::FaultKind>>& double_faults();

/// Runs the E1 matrix (the nominal row first). The scenario is run with the plausibility stage on
/// (every check: it cannot be switched off) and its start-up tare as configured. `progress` (optional) gets each row as it finishes.
std::vector<FaultRow> run_fault_matrix(E1Scenario scenario, const FaultMatrixOptions& options,
                                       const std::function<void(const FaultRow&)>& progress = {});

/// Runs the E3 matrix on the right arm the same way: the nominal row (to the latest moment's end)
/// first, then every kind on kE3FaultJoint (muscle kinds on its agonist) at each moment. Throws
/// std::invalid_argument when options name an E3 case or a moment E3 does not have.
std::vector<FaultRow> run_fault_matrix(ArmScenario scenario, const FaultMatrixOptions& options,
                                       const std::function<void(const FaultRow&)>& progress = {});

/// faults.md (table + summary, naming the rows' experiment) and faults.csv in `dir`.
/// `after_fault_s` and `slow_after_fault_s` as the runs used (FaultMatrixOptions).
void write_fault_matrix(const std::filesystem::path& dir, const std::vector<FaultRow>& rows, const std::string& scenario_name,
                        double after_fault_s = 5.0, double slow_after_fault_s = 20.0);

}  // namespace peha::experiments
