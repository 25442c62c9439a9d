#pragma once
/// \file
/// The figures of the motion after a release that every experiment with releases (E1, E3) checks:
/// |drift|, the largest excursion (a swing that comes back has a small drift), and a run to a
/// joint stop.

#include "peha/safety/verdict.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace peha::experiments {

/// Distance (deg) of a joint to the nearer end of its range [min_rad, max_rad], at the release
/// sample k0 and at its closest over the window k0..k1 of `angle_rad`.
struct StopDistance {
  double at_release_deg = 0;
  double closest_deg = 0;
};
StopDistance stop_distance(const std::vector<double>& angle_rad, std::size_t k0, std::size_t k1, double min_rad, double max_rad);

/// Adds "<what> |drift|", "<what> max excursion" (both <= max_drift_deg) and, when the joint was
/// released at least stop_margin_deg from a stop (a posture at the end of the range is not a run to
/// it), "<what> distance to a stop" (>= stop_margin_deg over the window).
void add_release_checks(const std::string& what, double drift_deg, double max_excursion_deg, const StopDistance& stop,
                        const safety::VerdictThresholds& thresholds, safety::Verdict& verdict);

}  // namespace peha::experiments
