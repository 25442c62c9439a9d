#pragma once
/// \file
/// Experiment E6: the torque bandwidth of one arm joint (`bandwidth.joint`, any peha or pam_pair joint)
/// with the arm locked at a posture (a torque bench), PAM-only vs hybrid (PAMs + motor): sine torques
/// at each frequency of the scenario's sweep, the delivered torque's gain and phase, and the -3 dB
/// frequency.

#include "peha/experiments/arm/arm_scenario.hpp"

#include <string>
#include <vector>

namespace peha::experiments {

struct BodePoint {
  double frequency_Hz = 0;
  double gain = 0;        ///< |delivered / desired| of the torque at this frequency
  double phase_deg = 0;   ///< arg(delivered / desired)
};

/// The widest run of frequencies over which the gain stays at or above 1/sqrt(2) (-3 dB), its edges
/// log-interpolated; an edge at the end of the sweep is that frequency and open ("> 30 Hz"). A
/// high-pass response (the hybrid at a clamped joint: the motor passes, the cables do not) has a
/// band with a lower edge; empty() when no frequency reaches -3 dB.
struct PassBand {
  double low_Hz = 0, high_Hz = 0;
  bool open_low = false, open_high = false;  ///< the edge is the sweep's end: the band may go further
  bool empty() const { return high_Hz <= 0.0; }
};

/// The widest -3 dB band of `bode` (ascending frequencies).
PassBand pass_band_3dB(const std::vector<BodePoint>& bode);

struct BandwidthResult {
  std::string variant;                 ///< "pam_only" or "hybrid"
  /// Delivered = the actuator's torque as the muscles and motor produce it: muscle-side wire
  /// tensions x pulley radius + motor (what load cells at the muscles and the motor current tell).
  std::vector<BodePoint> bode;
  double bandwidth_3dB_Hz = 0;         ///< where the gain first falls below 1/sqrt(2) (log-interpolated);
                                       ///< the highest frequency tested if it never does, the lowest if
                                       ///< the gain is below it already there (reached_3dB false both times)
  bool reached_3dB = false;
  /// Delivered at the joint, after the cable: the wires' tensions where they leave the housing at the
  /// pulley (the capstan's stick band with memory, sim::PehaJointTruth) x pulley radius + motor - what
  /// a torque sensor between the joint and the lock reads. Below the first frequency's gain of
  /// 1/sqrt(2) the bandwidth is reported as that frequency with reached = false ("< f").
  std::vector<BodePoint> bode_at_joint;
  double bandwidth_3dB_at_joint_Hz = 0;
  bool reached_3dB_at_joint = false;
  /// Where the joint receives at least -3 dB of the command: the hybrid's motor band at a clamped
  /// joint, which the -3 dB point counted from the lowest frequency does not show.
  PassBand pass_band_at_joint;
  double peak_muscle_force_N = 0;
  double min_wire_tension_N = 0;
  double peak_motor_torque_Nm = 0;
  safety::Verdict verdict;             ///< the safety envelope over every joint (safety/verdict.hpp)
  bool within_limits = false;          ///< verdict.passed()
};

/// E6: the torque bandwidth of one joint, PAM-only (no motor, no low-pass split) or hybrid.
BandwidthResult run_bandwidth(const ArmScenario& scenario, bool hybrid);

}  // namespace peha::experiments
