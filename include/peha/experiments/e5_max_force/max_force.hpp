#pragma once
/// \file
/// Experiment E5 (docs/e5-max-force.md, paper Fig. 7): the maximum-force test. The one-DOF rig's
/// joint is clamped; one muscle's pressure command ramps up at a constant rate and never stops by
/// itself. The limits stage at the backend boundary (safety::LimitedBackend) caps the pressure at
/// the one that makes the muscle's force ceiling by the controller's muscle model; E5 measures
/// whether the load cell's force then stops at the ceiling (peak, overshoot, time to hold, time at
/// the limit, pressure at the limit) and which mechanism stopped it. The scenario is entirely
/// configuration (configs/e5_max_force.yaml).

#include "peha/hardware/door.hpp"
#include "peha/config/reader.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/models/joint.hpp"
#include "peha/runtime/log_telemetry.hpp"
#include "peha/runtime/control_loop.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/limits.hpp"
#include "peha/safety/verdict.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include <optional>
#include <string>
#include <vector>

namespace peha::experiments {

/// One ramp against the clamp: the clamp's angle sets the muscle's length (the paper ran the test
/// from four initial lengths).
struct E5Case {
  std::string name;            ///< used in file names, e.g. "angle_0deg"
  double locked_angle_rad = 0; ///< where the clamp holds the joint
};

/// The pressure ramp on one muscle, the other held at the pretension.
struct E5Ramp {
  int muscle = 0;                    ///< 0 agonist, 1 antagonist
  double start_s = 0.5;              ///< the command holds start_pressure_Pa until then
  double start_pressure_Pa = 0.1e6;  ///< gauge
  double rate_Pa_per_s = 0.1e6;      ///< the command rises this fast, without end
  double other_pressure_Pa = 0.25e6; ///< the other muscle's constant pressure (keeps its wire taut), gauge
};

struct E5Scenario {
  std::string description;
  std::uint64_t seed = 1;
  double period_s = 1e-3;
  double duration_s = 12;
  E5Ramp ramp;
  models::JointModel joint;          ///< the controller's joint set-up (the limits read it)
  safety::LimitsModel limits;
  safety::VerdictThresholds verdict; ///< the optional `verdict:` section
  sim::OneDofRigParams plant;        ///< model file with the "lock" clamp; initial angle set per case
  std::vector<E5Case> cases;
  std::optional<mfb::LinkConfig> link;  ///< optional `mfb:` section: the run over the board
  /// The lifecycle supervisor's parameters (`lifecycle:`): the same in process and on the board.
  runtime::SupervisorParams lifecycle;
  /// The scenario's live telemetry (`telemetry:`, runtime::read_telemetry): what streams unless the command line says otherwise.
  runtime::TelemetryOptions telemetry;
};

/// Reads a whole E5 scenario file; throws config::Error on anything the schema does not accept.
E5Scenario read_e5(const config::Document& doc);

/// What capped the ramped muscle's pressure command in one cycle.
enum class E5Stop {
  kNone,          ///< nothing: the ramp's own pressure went out
  kForceCeiling,  ///< the limits' pressure ceiling from the muscle model's force ceiling
  kSupply,        ///< the limits' pressure ceiling at the supply (the model reaches the force ceiling only above it)
  kRateLimit,     ///< the limits' pressure rate limit alone
  kSupervisor,    ///< the outputs were not active (fault, e-stop, watchdog: safe outputs)
};
const char* to_string(E5Stop stop) noexcept;

struct E5Result {
  std::string case_name;
  std::string muscle;                 ///< "agonist" / "antagonist"
  double locked_angle_deg = 0;
  double limit_N = 0;                 ///< the muscle's force ceiling (models::force_ceiling_N)
  double peak_force_N = 0;            ///< highest load-cell force of the ramped muscle
  double overshoot_N = 0;             ///< max(0, peak - limit)
  double overshoot_pct = 0;           ///< 100 x overshoot / limit
  double peak_truth_force_N = 0;      ///< the plant's muscle force, highest (NaN over the board)
  double held_force_N = 0;            ///< the load cell's mean over the last second: where the force stopped
  double shortfall_N = 0;             ///< limit - held force (> 0: the model's ceiling stops the force early)
  double reach_s = 0;                 ///< first cycle the limits capped the ramp: the limit reached (NaN: never)
  double settle_s = 0;                ///< from reach_s until the force stays within the band of the held force to the end
  double time_at_limit_s = 0;         ///< from then to the end: time held at the limit (0 if never reached)
  double pressure_at_limit_MPa = 0;   ///< mean pressure sensor reading while held
  double pressure_cmd_at_limit_MPa = 0;  ///< mean pressure command sent while held
  double ceiling_share_pct = 0;       ///< of the held cycles, % whose ramp the limits' force ceiling capped
  E5Stop stop = E5Stop::kNone;        ///< what capped the command most often while held
  double max_clamp_deflection_deg = 0;  ///< largest |angle - clamp angle| (encoder)
  std::uint64_t stop_counts[5] = {0, 0, 0, 0, 0};  ///< held cycles by E5Stop
  safety::Verdict verdict;
  bool passed = false;
  bool from_truth = true;             ///< the envelope from the simulator's truth (in-process) or the sensors
  double simulated_s = 0;
  double realtime_factor = 0;
  std::uint64_t missed_samples = 0;
  std::uint64_t limit_counts[5] = {0, 0, 0, 0, 0};  ///< by safety::LimitFlag bit
};

/// Column names of the per-cycle log.
const std::vector<std::string>& e5_log_columns();

/// The simulated rig of a case: the scenario's plant, clamped at the case's angle.
sim::OneDofRigParams e5_plant_params(const E5Scenario& scenario, const E5Case& c);
/// What a case declares to the hardware door: the rig's one joint, the scenario's period and mfb:
/// section (one board), the clamped rig (sim:), the log's unprefixed sensor columns (replay:).
hardware::HardwareRequest e5_hardware(const E5Scenario& scenario, const E5Case& c);

/// One case on the in-process simulated rig. `log` (optional) receives one row per cycle.
E5Result run_e5_case(const E5Scenario& scenario, const E5Case& c, runtime::RowSink* log);

/// One case on any backend: the same ramp, limits and analysis. `sim` (optional) is the in-process
/// rig when `backend` is it (truth figures); without it the envelope reads the sensors.
E5Result run_e5_on(const E5Scenario& scenario, const E5Case& c, io::Backend& backend, const sim::OneDofRigBackend* sim,
                   runtime::RowSink* log, const runtime::CycleHooks& hooks = {});

}  // namespace peha::experiments
