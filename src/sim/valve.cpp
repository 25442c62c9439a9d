#include "peha/sim/valve.hpp"

#include <algorithm>
#include <cmath>

namespace peha::sim {

ValveParams read_valve(config::Map& map, double supply_pressure_Pa) {
  ValveParams p;
  p.dead_time_s = map.number("dead_time_s", {0.0, 0.5});
  p.lag_s = map.number("lag_s", {1e-4, 2.0});
  p.rate_limit_Pa_per_s = map.number("rate_limit_MPa_per_s", {0.01, 100.0}) * 1e6;
  p.supply_pressure_Pa = supply_pressure_Pa;
  map.finish();
  return p;
}

Valve::Valve(const ValveParams& params, double dt_s)
    : params_(params),
      dt_s_(dt_s),
      lag_blend_(1.0 - std::exp(-dt_s / params.lag_s)),
      delay_(static_cast<std::size_t>(std::lround(params.dead_time_s / dt_s)) + 1, 0.0),
      supply_now_Pa_(params.supply_pressure_Pa) {}

void Valve::reset(double pressure_Pa) noexcept {
  std::fill(delay_.begin(), delay_.end(), pressure_Pa);
  setpoint_Pa_ = pressure_Pa_ = pressure_Pa;
}

double Valve::step(double command_Pa) noexcept {
  if (!std::isfinite(command_Pa)) command_Pa = 0.0;  // a valve without a valid command vents
  command_Pa = std::clamp(command_Pa, 0.0, params_.supply_pressure_Pa);
  delay_[head_] = command_Pa;
  if (++head_ == delay_.size()) head_ = 0;  // a ring: no integer division per step
  const double delayed = delay_[head_];  // oldest entry: written delay_.size()-1 steps ago
  const double max_step = params_.rate_limit_Pa_per_s * dt_s_;
  setpoint_Pa_ += std::clamp(delayed - setpoint_Pa_, -max_step, max_step);
  const double before = pressure_Pa_;
  pressure_Pa_ += lag_blend_ * (setpoint_Pa_ - pressure_Pa_);
  // Filling stops at the supply line's pressure; above it a check valve keeps the chamber's air.
  const double ceiling = std::min(params_.supply_pressure_Pa, std::max(before, supply_now_Pa_));
  pressure_Pa_ = std::clamp(pressure_Pa_, 0.0, ceiling);
  return pressure_Pa_;
}

}  // namespace peha::sim
