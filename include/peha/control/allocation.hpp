#pragma once
/// \file
/// Torque allocation of one PEHA joint: the macro-mini split (docs/models.md).
///
/// - Macro (PAMs): the low-pass filtered desired torque (first order, `pam_cutoff_Hz`). A torque
///   >= 0 goes to the agonist, < 0 to the antagonist; the other muscle keeps the pretension. Each
///   pulley force is converted to a muscle force through the Bowden model, clamped to
///   [pretension_N, max_force_N], and to a pressure through the muscle's pressure model
///   (models::muscle_pressure: inverse Tendon-spring + learned residual), clamped to [0, supply].
///   Supply and pretension are the joint's (models::JointModel).
/// - Force trim (optional, `force_trim_rate_1ps` > 0): a slow integral of each muscle's force error
///   (commanded muscle-side force minus its load cell) is added to the force handed to the inverse
///   model, bounded by `force_trim_max_N` and frozen while the pressure is saturated (anti-windup).
///   Working in force, it passes through the model's own gain, so both muscles get about the same
///   bandwidth (rate / 2 pi). It removes the steady error of the parametric model (e.g. the PAM's
///   pressure threshold, which the 5-parameter model cannot represent) with force sensing only:
///   there is still no position feedback. 0 gives the paper's pure feed-forward p* = g^-1(F*).
///   Bumpless start: on the first step the trim is initialised so that the command equals the
///   measured pressure, so switching the controller on does not step the valves.
/// - Mini (motor): the desired torque minus the PAM torque *measured* by the load cells (through
///   the Bowden model), saturated at the motor rating. It supplies the high-frequency part and what
///   the PAM and cable models get wrong.
///
/// Model/Data split: `JointModel` and `AllocationParams` are constant; `AllocationData` holds the
/// filter state. `allocate` is noexcept and allocation-free.

#include "peha/config/reader.hpp"
#include "peha/models/joint.hpp"

#include <cstdint>

namespace peha::control {

struct AllocationParams {
  double pam_cutoff_Hz = 5.0;       ///< cut-off of the PAM share's first-order low-pass, Hz
  bool use_motor = true;            ///< false: PAM-only joint (the motor command is 0)
  double force_trim_rate_1ps = 0.0;  ///< integral gain of the force trim, 1/s (0 = off)
  double force_trim_max_N = 200.0;   ///< bound of the trim's force correction, N
  /// The control period, s (the scenario's run.control_period_s): the step the controllers use
  /// when the sample time stamps give none (first sample, or a bad stamp).
  double period_s = 1e-3;
};

/// Reads an `allocation:` mapping (pam_cutoff_Hz, pretension_N, use_motor, force_trim_rate_1ps,
/// force_trim_max_N) and finishes it. The pretension belongs to the joints (models::JointModel::
/// pretension_N): it is returned in `pretension_N` for the scenario to put there.
AllocationParams read_allocation(config::Map map, double& pretension_N);

/// Flags raised when a limit shaped the command (bitwise or of AllocationFlag).
enum AllocationFlag : std::uint32_t {
  kForceClampedHigh = 1u << 0,   ///< a muscle force was cut to its ceiling
  kPressureSaturated = 1u << 1,  ///< the inverse model asked for more than the supply
  kMotorSaturated = 1u << 2,     ///< the motor share was cut to its rating
  kNonFiniteInput = 1u << 3,     ///< an input was NaN/inf; the command holds safe values
};

struct AllocationInput {
  double tau_desired_Nm = 0;
  double angle_rad = 0;
  double velocity_radps = 0;
  double agonist_loadcell_N = 0;
  double antagonist_loadcell_N = 0;
  double agonist_pressure_Pa = 0;     ///< measured; used for the bumpless start only
  double antagonist_pressure_Pa = 0;  ///< measured; used for the bumpless start only
  double dt_s = 1e-3;
};

struct AllocationOutput {
  double tau_pam_cmd_Nm = 0;          ///< PAM share after the low-pass (desired)
  double tau_pam_measured_Nm = 0; ///< PAM torque from the load cells through the Bowden model
  double tau_motor_cmd_Nm = 0;        ///< motor command at the joint
  double agonist_force_cmd_N = 0;        ///< commanded muscle-side force of the agonist
  double antagonist_force_cmd_N = 0;     ///< commanded muscle-side force of the antagonist
  double agonist_pressure_Pa = 0;
  double antagonist_pressure_Pa = 0;
  double agonist_contraction = 0;    ///< rigid-wire contraction used for the inverse model
  double antagonist_contraction = 0;
  double agonist_trim_N = 0;         ///< force trim added to the agonist's model request
  double antagonist_trim_N = 0;
  std::uint32_t flags = 0;
};

/// Filter state.
struct AllocationData {
  double tau_pam_filtered_Nm = 0;
  double force_trim_N[2] = {0, 0};  ///< integral force corrections, agonist and antagonist
  bool initialized = false;
};

/// One allocation step. Never throws, never allocates; every output is finite and within limits.
void allocate(const models::JointModel& joint, const AllocationParams& params, AllocationData& data,
              const AllocationInput& in, AllocationOutput& out) noexcept;

}  // namespace peha::control
