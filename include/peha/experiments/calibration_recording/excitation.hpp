#pragma once
/// \file
/// Calibration excitation (docs/calibration.md, paper Fig. 8): a triangle wave of pressure on one muscle while
/// the other holds a constant pressure and the joint moves; the load cell, the valve's pressure and
/// the joint angle are logged at 250 Hz. It drives any `io::Backend` (the simulated rig by default,
/// the I/O board later) through the limits layer like every other command.

#include "peha/calibration/dataset.hpp"
#include "peha/config/reader.hpp"
#include "peha/io/backend.hpp"
#include "peha/models/joint.hpp"
#include "peha/safety/limits.hpp"

#include <functional>
#include <string>

namespace peha::experiments {

/// The excitation of one muscle.
struct ExcitationParams {
  double min_pressure_Pa = 0.05e6;    ///< bottom of the triangle
  double max_pressure_Pa = 0.45e6;    ///< top of the triangle
  double period_s = 12.0;             ///< one up-and-down
  double duration_s = 60.0;           ///< total
  double other_pressure_Pa = 0.25e6;  ///< the other muscle's pressure while the excited one is at its top
  /// The other muscle's pressure while the excited one is at its bottom; in between it moves in
  /// antiphase, so the link is driven through its range both ways despite the cable stiction.
  /// Equal to other_pressure_Pa: constant.
  double other_pressure_at_min_Pa = 0.25e6;
  double sample_rate_Hz = 250.0;      ///< logging rate (a divisor of the control rate)
  double payload_kg = 2.5;            ///< weight on the link while recording (simulated rig)
};

/// Reads one muscle's `calibration.<muscle>` mapping (pressures in MPa) and finishes it.
ExcitationParams read_excitation(config::Map map);

/// Triangle wave value at time t: min at t = 0, max at period/2.
double triangle_pressure_Pa(const ExcitationParams& e, double t_s) noexcept;
/// The other muscle's pressure at time t (antiphase between its two values).
double other_pressure_Pa(const ExcitationParams& e, double t_s) noexcept;

/// Runs the excitation of muscle `side` (+1 agonist, -1 antagonist) of joint 0 on `backend` and
/// returns the logged data (contraction from the controller's rigid-wire geometry, wire velocity
/// from a filtered encoder difference). `progress(fraction)` is called about once per second of data.
calibration::Dataset record_excitation(io::Backend& backend, const models::JointModel& joint, int side,
                          const ExcitationParams& excitation, const safety::LimitsModel& limits,
                          const std::function<void(double)>& progress = {});

}  // namespace peha::experiments
