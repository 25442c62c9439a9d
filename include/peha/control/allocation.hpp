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

#include <array>
#include <cstdint>

namespace peha::control {

/// How far a load cell is trusted (docs/models.md, "Load cells checked, not trusted").
struct LoadcellCheck {
  /// A load cell agrees with the pressure model while |reading - F_model(P_measured, eps)|, low-pass
  /// filtered at `filter_Hz`, stays within `tolerance_N + tolerance_fraction * F_model`. It counts
  /// as agreeing again once that falls below `rejoin_fraction` of the tolerance.
  double tolerance_N = 150.0;
  double tolerance_fraction = 0.6;
  double filter_Hz = 5.0;
  double rejoin_fraction = 0.7;
  /// Start-up tare (one-DOF controller): command both muscles vented for `vent_s` (the limits
  /// layer holds them at the model's pretension pressure, below the real muscles' pressure
  /// threshold), then average the load cells over `tare_s` (0 = no tare) and subtract that from
  /// every later reading. An offset beyond `max_tare_N` is not believed (kept 0).
  double tare_s = 0.0;
  double vent_s = 0.4;
  double max_tare_N = 200.0;
  /// After the tare the muscles fill again from vented: the wires are taut to the pretension floor
  /// about this long after compensation starts (what the experiments' tension figure allows for).
  double refill_s = 0.8;
};

struct AllocationParams {
  double pam_cutoff_Hz = 5.0;       ///< cut-off of the PAM share's first-order low-pass, Hz
  bool use_motor = true;            ///< false: PAM-only joint (the motor command is 0)
  double force_trim_rate_1ps = 0.0;  ///< integral gain of the force trim, 1/s (0 = off)
  double force_trim_max_N = 200.0;   ///< bound of the trim's force correction, N
  /// Integral gain of the trim while the muscle's load cell reads below the pretension and the force
  /// wanted is above it (the wire near slack), 1/s; the larger of this and force_trim_rate_1ps. 0 = off.
  double force_trim_slack_rate_1ps = 0.0;
  /// Fraction of the controller's cable friction (models::BowdenParams::friction_coefficient) the
  /// plant's cables are sure to have, in [0, 1]. The velocity-dependent Bowden compensation (the
  /// muscle command and the motor's estimate of the PAM torque) uses only this much
  /// (models::sure_friction), so it can never act as positive velocity feedback on a cable with
  /// less friction than the model. 1 is the old, full compensation; 0 (default) none.
  double sure_cable_friction_fraction = 0.0;
  /// Viscous damping the motor adds at the joint, Nm s/rad: tau_motor -= b * omega_hat. Passive
  /// (it only ever takes energy out), so it damps what the plant's friction would otherwise have to:
  /// a cable with no friction leaves the link with almost no damping (docs/models.md). 0 = none.
  double motor_damping_Nms_per_rad = 0.0;
  LoadcellCheck loadcell_check;
  /// The control period, s (the scenario's run.control_period_s): the step the controllers use
  /// when the sample time stamps give none (first sample, or a bad stamp).
  double period_s = 1e-3;
};

/// Reads an `allocation:` mapping (pam_cutoff_Hz, pretension_N, use_motor, force_trim_rate_1ps,
/// force_trim_max_N; optional sure_cable_friction_fraction and loadcell_check{...}) and finishes it. The pretension belongs to the joints (models::JointModel::
/// pretension_N): it is returned in `pretension_N` for the scenario to put there.
AllocationParams read_allocation(config::Map map, double& pretension_N);

/// Flags raised when a limit shaped the command (bitwise or of AllocationFlag).
enum AllocationFlag : std::uint32_t {
  kForceClampedHigh = 1u << 0,   ///< a muscle force was cut to its ceiling
  kPressureSaturated = 1u << 1,  ///< the inverse model asked for more than the supply
  kMotorSaturated = 1u << 2,     ///< the motor share was cut to its rating
  kNonFiniteInput = 1u << 3,     ///< an input was NaN/inf; the command holds safe values
  /// A load cell disagrees with the pressure model beyond LoadcellCheck's tolerance: that muscle's
  /// trim is frozen and the motor uses the model's force for it (AllocationOutput::loadcell_ok).
  kLoadcellDisagrees = 1u << 4,
  /// The trim was held so that the model's force (force + trim) stays at least the pretension.
  kTensionFloorByModel = 1u << 5,
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
  /// False while the wires are slack on purpose (the start-up tare's vent and refill): the trim's
  /// slack rate waits, as the wires are still taking up their slack from vented.
  bool tension_expected = true;
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
  /// Pressure model's force at the measured pressure and contraction, N (agonist, antagonist):
  /// what the load cells are checked against.
  double model_force_N[2] = {0, 0};
  bool loadcell_ok[2] = {true, true};  ///< each load cell agrees with the model (agonist, antagonist)
  std::uint32_t flags = 0;
};

/// Filter state.
struct AllocationData {
  double tau_pam_filtered_Nm = 0;
  double force_trim_N[2] = {0, 0};  ///< integral force corrections, agonist and antagonist
  bool initialized = false;
  /// On the first step the trim starts so that the command equals the measured pressure. A
  /// controller that vented the muscles for a tare clears this: the trim then starts at 0.
  bool bumpless_start = true;
  double loadcell_offset_N[2] = {0, 0};   ///< tare, subtracted from each reading (agonist, antagonist)
  double disagreement_N[2] = {0, 0};      ///< low-passed reading - model force
  bool loadcell_ok[2] = {true, true};     ///< each load cell currently trusted
  /// Added to each muscle's rigid-wire contraction before its pressure model (agonist, antagonist),
  /// dimensionless: a wire longer by dL lets the muscle contract dL / L0 further at the same angle
  /// (the creep estimator's correction, control/wire_creep_estimator.hpp). 0 = the model as set up.
  double contraction_offset[2] = {0, 0};
};

/// The muscles were not driven by this allocation's commands for a while (an outage, a safe state,
/// the supervisor's hold): the next step starts from what is measured, as the very first one does -
/// the trim so that the command is the measured pressure, the torque filter at the desired torque -
/// not from what it integrated against commands that never went out. noexcept.
inline void resume_allocation(AllocationData& data) noexcept {
  data.initialized = false;
  data.bumpless_start = true;
}

/// The zeros this allocation subtracts from the load cells, as a command declares them to the
/// supervisor (io::JointCommand::loadcell_zero_N). noexcept.
inline std::array<double, 2> declared_zero(const AllocationData& data) noexcept {
  return {data.loadcell_offset_N[0], data.loadcell_offset_N[1]};
}

/// One allocation step. Never throws, never allocates; every output is finite and within limits.
void allocate(const models::JointModel& joint, const AllocationParams& params, AllocationData& data,
              const AllocationInput& in, AllocationOutput& out) noexcept;

}  // namespace peha::control
