#pragma once
/// \file
/// The parameters of the one-DOF rig's sensor check (experiments/sensor_check/sensor_check.hpp), read
/// from an E1 scenario's optional `sensor_check:` section.

#include "peha/config/reader.hpp"

namespace peha::experiments {

/// The scenario's `sensor_check:` section (angles in degrees, pressures in MPa in the file).
struct SensorCheckParams {
  double known_mass_kg = 2.5;        ///< the mass placed on the link (weighed on a scale)
  double lever_m = 0.4;              ///< its centre's distance from the joint axis
  double check_angle_rad = 0.0;      ///< where each sweep is measured
  double sweep_rad = 0.07;           ///< the reference moves +-this around the check angle
  double sweep_speed_radps = 0.035;
  double window_rad = 0.017;         ///< samples within this of the check angle are averaged
  double min_speed_fraction = 0.3;   ///< only samples moving at least this x the sweep speed, the right way
  double antagonist_force_N = 150.0; ///< run 2: the antagonist's force at the check angle (by its model)
  double vent_s = 0.4, tare_s = 0.5; ///< the vented zero: vent, then average (the start-up tare's rule)
  /// The pin is pulled this long after the start: after the vented zero, the agonist's pressure is
  /// integrated on its load cell until it carries the link (the start-up's rule: never pull the pin
  /// under a wire that does not carry).
  double pin_s = 2.0;
  double force_gain_Pa_per_N_s = 1.5e3;           ///< that refill: dp/dt per N of force error
  /// After the pin, the agonist's pressure loop on the encoder's speed: the pressure ramps by
  /// speed_integral x (sweep speed - speed) per second (through the cable's stiction band while the
  /// link sticks), plus speed_gain x that error (the damping of the slide).
  double speed_integral_Pa_per_rad = 0.57e6;
  double speed_gain_Pa_s_per_rad = 0.36e6;
  /// A cell whose vented reading sits at code 0 this often has its zero below its range.
  double max_code0_fraction = 0.9;
  double duration_s() const noexcept;
};

/// Reads `sensor_check:` and finishes it.
SensorCheckParams read_sensor_check(config::Map map);

}  // namespace peha::experiments
