#pragma once
/// \file
/// Experiment E6: the torque bandwidth of one right-arm joint locked at a posture (a torque bench),
/// PAM-only vs hybrid (PAMs + motor): sine torques at each frequency of the scenario's sweep, the
/// delivered torque's gain and phase, and the -3 dB frequency.

#include "peha/experiments/right_arm/arm_scenario.hpp"

#include <string>
#include <vector>

namespace peha::experiments {

struct BodePoint {
  double frequency_Hz = 0;
  double gain = 0;        ///< |delivered / desired| of the torque at this frequency
  double phase_deg = 0;   ///< arg(delivered / desired)
};

struct BandwidthResult {
  std::string variant;                 ///< "pam_only" or "hybrid"
  std::vector<BodePoint> bode;
  double bandwidth_3dB_Hz = 0;         ///< where the gain first falls below 1/sqrt(2) (log-interpolated);
                                       ///< the highest frequency tested if it never does
  bool reached_3dB = false;
  double peak_muscle_force_N = 0;
  double min_wire_tension_N = 0;
  double peak_motor_torque_Nm = 0;
  safety::Verdict verdict;             ///< the safety envelope over every joint (safety/verdict.hpp)
  bool within_limits = false;          ///< verdict.passed()
};

/// E6: the torque bandwidth of one joint, PAM-only (no motor, no low-pass split) or hybrid.
BandwidthResult run_bandwidth(const ArmScenario& scenario, bool hybrid);

}  // namespace peha::experiments
