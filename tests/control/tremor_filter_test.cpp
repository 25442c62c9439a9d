// The tremor filter (control/tremor_filter.hpp): a person's 4-12 Hz tremor out of a goniometer's
// reading, the voluntary movement not delayed.
#include "peha/control/tremor_filter.hpp"

#include "peha/models/units.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

namespace peha::control {
namespace {

using models::deg_to_rad;
using models::rad_to_deg;

/// E4's brisk person: minimum-jerk 40 -> 100 deg in 0.5 s and back, 0.3 s pauses, 5 strokes each way.
double voluntary_rad(double t_s) {
  const double move_s = 0.5, pause_s = 0.3, cycle_s = 2.0 * (move_s + pause_s);
  const double from = deg_to_rad(40.0), to = deg_to_rad(100.0);
  if (t_s >= 5.0 * cycle_s) return from;
  const double tc = std::fmod(t_s, cycle_s);
  auto mj = [](double s) { return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s); };
  if (tc < pause_s) return from;
  if (tc < pause_s + move_s) return from + (to - from) * mj((tc - pause_s) / move_s);
  if (tc < 2.0 * pause_s + move_s) return to;
  return to + (from - to) * mj((tc - 2.0 * pause_s - move_s) / move_s);
}

struct Figures {
  double rms_deg = 0;       ///< RMS of what the tremor filter leaves of the tremor, through E4's own low-pass
  double frequency_Hz = 0;  ///< the tremor's frequency as found at the end
};

/// The brisk person with a tremor of `amplitude_deg` at `frequency_Hz`, 0.2 deg noise, 200 Hz. The
/// figure: the voluntary estimate minus (the movement + the noise), both through E4's 6.5 Hz low-pass
/// (what follows the tremor filter), from the first second on - the tremor left and any lag added.
Figures run(double amplitude_deg, double frequency_Hz, const TremorFilterParams& p = {}) {
  const TremorFilterModel m = make_tremor_filter(p);
  TremorFilterData d = make_tremor_filter_data(m);
  ButterworthFilter estimate_lp(2, 6.5, 200.0), reference_lp(2, 6.5, 200.0);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, deg_to_rad(0.2));
  double sum = 0;
  int n = 0;
  for (int k = 0; k < 8 * 200; ++k) {
    const double t = k / 200.0;
    const double v = voluntary_rad(t), e = noise(rng);
    const double x = v + deg_to_rad(amplitude_deg) * std::sin(2.0 * std::numbers::pi * frequency_Hz * t) + e;
    const double y = tremor_filter_step(m, d, x);
    if (k == 0) estimate_lp.reset(y), reference_lp.reset(v + e);
    const double diff = estimate_lp.step(y) - reference_lp.step(v + e);
    if (t >= 1.0) sum += diff * diff, ++n;
  }
  const Figures f{rad_to_deg(std::sqrt(sum / n)), tremor_frequency_Hz(m, d)};
  std::printf("tremor %.1f deg at %.1f Hz: %.3f deg RMS of it left through E4's low-pass, frequency found %.2f Hz\n", amplitude_deg,
              frequency_Hz, f.rms_deg, f.frequency_Hz);
  return f;
}

// A 3 deg tremor at 6, 7 or 8 Hz on the brisk movement: through E4's own 6.5 Hz low-pass it would
// pass as 1.38 deg RMS (7 Hz); with the filter 0.48-0.76 deg is left once the first second has found
// it, and its frequency is found within 0.1 Hz. With no tremor the gate stays shut: 0.09 deg, the
// goniometer's noise through the filter's own fits. (A 1 deg tremor at 7 Hz: 0.58 deg left, about
// what it is unfiltered - the fast fit's noise; printed, not asserted.)
TEST(TremorFilter, ATremorIsTakenOutAndTheVoluntaryMovementIsLeft) {
  EXPECT_LT(run(0.0, 7.0).rms_deg, 0.1);
  for (const double f : {6.0, 7.0, 8.0}) {
    const Figures r = run(3.0, f);
    EXPECT_LT(r.rms_deg, 0.8) << f << " Hz";
    EXPECT_NEAR(r.frequency_Hz, f, 0.2) << f << " Hz";
  }
  (void)run(1.0, 7.0);
}

// The gate shut for good (gate_on beyond any fit): nothing is taken out, the tremor passes whole.
TEST(TremorFilter, WithTheGateShutTheTremorStays) {
  TremorFilterParams shut;
  shut.gate_on_rad = 1.0;
  shut.gate_full_rad = 2.0;
  EXPECT_GT(run(3.0, 7.0, shut).rms_deg, 1.3);
}

TEST(TremorFilter, BadParametersAreRefusedByName) {
  TremorFilterParams p;
  p.highpass_Hz = 5.0;  // above the band's bottom
  EXPECT_THROW(make_tremor_filter(p), std::invalid_argument);
  p = {};
  p.max_frequency_Hz = 120.0;
  EXPECT_THROW(make_tremor_filter(p), std::invalid_argument);
  p = {};
  p.gate_full_rad = p.gate_on_rad;
  EXPECT_THROW(make_tremor_filter(p), std::invalid_argument);
}

}  // namespace
}  // namespace peha::control
