#pragma once
/// \file
/// Pressure servo valve of the simulated plant: dead time, then a rate limit, then a first-order lag,
/// all bounded by the supply (docs/simulator.md).

#include "peha/config/reader.hpp"

#include <cstddef>
#include <vector>

namespace peha::sim {

struct ValveParams {
  double dead_time_s = 0.005;           ///< transport delay of the command, s
  double lag_s = 0.03;                  ///< time constant of the first-order response, s
  double rate_limit_Pa_per_s = 4e6;     ///< max |dP/dt| of the valve's set point, Pa/s
  double supply_pressure_Pa = 0.8e6;    ///< tank pressure, Pa (pressure never exceeds it)
};

/// Reads `dead_time_s`, `lag_s`, `rate_limit_MPa_per_s` and finishes the map (supply passed in).
ValveParams read_valve(config::Map& map, double supply_pressure_Pa);

class Valve {
 public:
  /// `dt_s`: the step at which `step` is called. Allocates the delay line here, never later.
  Valve(const ValveParams& params, double dt_s);
  /// Advances one step with a new command (Pa). Returns the chamber pressure (Pa). noexcept.
  double step(double command_Pa) noexcept;
  double pressure_Pa() const { return pressure_Pa_; }
  /// Sets the chamber pressure and the whole delay line to `pressure_Pa` (for initial conditions).
  void reset(double pressure_Pa) noexcept;
  /// What the supply line holds now (an injected supply fault; the valve's own supply by default).
  /// Behind a check valve: the chamber cannot fill above it, but does not empty into a dead line.
  void set_supply_Pa(double supply_Pa) noexcept { supply_now_Pa_ = supply_Pa; }

 private:
  ValveParams params_;
  double dt_s_;
  double lag_blend_;           ///< 1 - exp(-dt/lag): the first-order lag's step weight, once
  std::vector<double> delay_;  ///< ring buffer of past commands
  std::size_t head_ = 0;
  double setpoint_Pa_ = 0.0;
  double pressure_Pa_ = 0.0;
  double supply_now_Pa_;
};

}  // namespace peha::sim
