#pragma once
/// \file
/// Degrees and radians: the one place that converts between them. Inside peha every angle is in
/// rad (rad/s for speeds); degrees appear only at the edges: scenario files (`*_deg` keys), printed
/// figures, log columns and reports named `*_deg`.
///
///     kRadPerDeg = pi / 180     multiply degrees by it to get radians
///     kDegPerRad = 180 / pi     multiply radians by it to get degrees
///
/// The helpers compute exactly what the code computed before they existed, to the last bit:
/// `deg_to_rad(x)` is `x * kRadPerDeg` and `rad_to_deg(x)` is `x / kRadPerDeg`. Beware that the
/// written-out alternatives are not the same doubles: `x * std::numbers::pi / 180` (i.e.
/// `(x * pi) / 180`) differs from `x * kRadPerDeg` in the last bit for about a quarter of all x
/// (e.g. x = -12), and `x * kDegPerRad` from `x / kRadPerDeg` for about one x in thirteen. A
/// simulation is deterministic to the bit, so a round trip such as
/// `deg_to_rad(map.number_or("..._deg", rad_to_deg(p.x_rad), ...))` keeps `p.x_rad` as it was only if
/// every conversion keeps its form.
///
/// Header-only, constexpr, no dependencies; may be included by every layer that may include
/// models (not by config or io, see docs/architecture.md).

#include <numbers>

namespace peha::models {

/// Radians per degree, pi / 180: `angle_rad = angle_deg * kRadPerDeg`.
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;
/// Degrees per radian, 180 / pi: `angle_deg = angle_rad * kDegPerRad` (the same double as
/// 1 / kRadPerDeg and as the literal 57.29577951308232).
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

/// Degrees to radians: `deg * kRadPerDeg`.
constexpr double deg_to_rad(double deg) noexcept { return deg * kRadPerDeg; }

/// Radians to degrees: `rad / kRadPerDeg` (a division, as the code always did, not
/// `rad * kDegPerRad`, which can differ in the last bit; see the file comment).
constexpr double rad_to_deg(double rad) noexcept { return rad / kRadPerDeg; }

}  // namespace peha::models
