#pragma once
/// \file
/// Gravity compensation of the one-DOF PEHA rig (experiment E1, paper Fig. 9): feed-forward only,
/// no position feedback. The desired torque is the controller's own (nominal) gravity model of the
/// link and payload; the allocation turns it into two pressures and a motor torque.
///
///     tau_g(theta) = g * (m_link * l_com + m_payload * l_payload) * cos(theta)
///
/// theta = 0 is the link horizontal, positive up (the agonist lifts).

#include "peha/control/allocation.hpp"
#include "peha/control/startup_tare.hpp"
#include "peha/control/wire_creep_estimator.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"

namespace peha::control {

/// The controller's nominal gravity model of the rig.
struct OneDofGravityModel {
  double link_mass_kg = 0.6;
  double link_com_m = 0.2;        ///< distance joint axis -> link centre of mass, m
  double payload_mass_kg = 2.5;
  double payload_lever_m = 0.4;   ///< distance joint axis -> payload centre, m
  double gravity_mps2 = 9.81;
};

/// Torque that holds the rig still at `angle_rad`, Nm.
double gravity_torque_Nm(const OneDofGravityModel& g, double angle_rad) noexcept;

/// First-order low-passed finite difference of the encoder angle.
struct VelocityEstimator {
  double cutoff_Hz = 20.0;
  double previous_angle_rad = 0.0;
  double velocity_radps = 0.0;
  bool initialized = false;
  /// Feeds a new angle sample `dt_s` after the previous one; returns the estimate in rad/s.
  double update(double angle_rad, double dt_s) noexcept;
};

/// One load cell's correction from the rig's sensor check (`peha check-sensors`, docs/calibration.md
/// "Sensor check"): the controller uses (reading - zero_N) / gain. `gain` is the cell's effective
/// gain: its own gain x the controller's pulley radius / the rig's (for torque only their product
/// matters). Neutral: 0 N and 1.
struct LoadcellCorrection {
  double zero_N = 0.0;
  double gain = 1.0;
};

/// The force the controller believes from a raw reading, N.
inline double corrected_loadcell_N(const LoadcellCorrection& c, double reading_N) noexcept {
  return (reading_N - c.zero_N) / c.gain;
}

struct OneDofControllerModel {
  models::JointModel joint;
  /// Per load cell (agonist, antagonist): applied to every reading before the start-up tare and the
  /// allocation see it (`controller.sensor_corrections`).
  LoadcellCorrection loadcell[2];
  OneDofGravityModel gravity;
  AllocationParams allocation;
  double velocity_cutoff_Hz = 20.0;
  /// Online tracking of wire creep and slack (control/wire_creep_estimator.hpp; off by default).
  CreepEstimatorParams creep;
};

/// What one step computed (for logs and plots).
struct OneDofDiagnostics {
  StartupPhase phase = StartupPhase::kCompensating;
  double loadcell_offset_N[2] = {0, 0};  ///< the tare (agonist, antagonist), once done
  double velocity_radps = 0;
  double tau_desired_Nm = 0;
  AllocationInput allocation_input;  ///< what the allocation was given this step
  AllocationOutput allocation;
  CreepEstimatorData creep;  ///< the creep estimator's state after this step (alerts latched there)
};

class OneDofGravityController {
 public:
  explicit OneDofGravityController(OneDofControllerModel model);
  /// One control step: sensors in, command out. noexcept, allocation-free.
  void update(const io::SensorState& state, io::Command& command) noexcept;
  const OneDofDiagnostics& diagnostics() const { return diag_; }
  const OneDofControllerModel& model() const { return model_; }
  /// The start-up (control/startup_tare.hpp): vent, tare the load cells, then compensate; without
  /// a tare it compensates from the first step. True while the wires are slack on purpose.
  bool wires_slack_on_purpose(double t_s) const noexcept {
    return control::wires_slack_on_purpose(model_.allocation.loadcell_check, tare_, t_s);
  }
  /// The operator's recovery after a fault: its commands did not go out meanwhile (held, governed,
  /// vented), so the next step starts from the measured pressures (control::resume_allocation), not
  /// from what it integrated against them. noexcept.
  void resume() noexcept { resume_allocation(allocation_data_); }

 private:
  const OneDofControllerModel model_;
  AllocationData allocation_data_;
  VelocityEstimator velocity_;
  OneDofDiagnostics diag_;
  double last_time_s_ = 0.0;
  bool started_ = false;
  StartupTare tare_;
};

}  // namespace peha::control
