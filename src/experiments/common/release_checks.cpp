#include "peha/experiments/common/release_checks.hpp"

#include "peha/models/units.hpp"

#include <algorithm>

namespace peha::experiments {

StopDistance stop_distance(const std::vector<double>& angle_rad, std::size_t k0, std::size_t k1, double min_rad, double max_rad) {
  auto distance = [&](double a) { return std::min(a - min_rad, max_rad - a) * models::kDegPerRad; };
  StopDistance d;
  d.at_release_deg = distance(angle_rad[k0]);
  d.closest_deg = d.at_release_deg;
  for (std::size_t k = k0; k <= k1 && k < angle_rad.size(); ++k) d.closest_deg = std::min(d.closest_deg, distance(angle_rad[k]));
  return d;
}

void add_release_checks(const std::string& what, double drift_deg, double max_excursion_deg, const StopDistance& stop,
                        const safety::VerdictThresholds& t, safety::Verdict& v) {
  v.at_most(what + " |drift|", "deg", std::abs(drift_deg), t.max_drift_deg);
  v.at_most(what + " max excursion", "deg", max_excursion_deg, t.max_drift_deg);
  if (stop.at_release_deg >= t.stop_margin_deg) v.at_least(what + " distance to a stop", "deg", stop.closest_deg, t.stop_margin_deg);
}

}  // namespace peha::experiments
