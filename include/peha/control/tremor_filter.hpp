#pragma once
/// \file
/// A person's tremor taken out of a joint-angle sensor without delaying the voluntary movement
/// (E4: the goniometer; docs/right-arm.md, E4 "The tremor"). The exoskeleton follows what the person
/// means to do; following a 4-12 Hz tremor would buzz the motor and shake the limb.
///
/// The weighted-frequency Fourier linear combiner (WFLC; Riviere, Rader and Thakor, IEEE TBME 45(5),
/// 1998) of one harmonic: a sine of adaptive frequency omega (rad/sample) and weights (w1, w2) is fitted
/// by LMS to the sensor's high-passed signal s (a Butterworth high-pass below the tremor band, so the
/// voluntary movement does not pull the fit), and a second, faster fit (v, step tracking_rate) at the
/// same phase follows the tremor's amplitude as it starts and stops:
///
///   x = (sin phi, cos phi),  e = s - w . x,  w += 2 mu e x,
///   omega += 2 mu0 e (w1 x2 - w2 x1) / (|w|^2 + a0^2),  phi += omega,
///
/// omega clamped to the model's band. The high-pass's response H at omega is known, so the tremor in
/// the raw signal is the fast fit rotated and scaled back by 1 / H(omega); the voluntary estimate is the
/// reading minus g x that tremor, g in [0, 1] a gate that opens with the fitted amplitude between
/// gate_on_rad and gate_full_rad (no tremor, nothing subtracted: noise fits a small sine). A pure
/// tremor sine is removed with no lag of the voluntary movement (a notch filter of the same depth
/// would delay a 2 Hz movement by 5-12 ms).
///
/// Model/Data: `make_tremor_filter` throws std::invalid_argument on bad parameters; `tremor_filter_step`
/// is noexcept and allocation-free.

#include "peha/control/butterworth.hpp"

#include <array>
#include <complex>

namespace peha::control {

struct TremorFilterParams {
  double sample_rate_Hz = 200.0;
  double min_frequency_Hz = 4.0;    ///< the band the tremor's frequency is searched in
  double max_frequency_Hz = 12.0;
  double initial_frequency_Hz = 7.0;
  double highpass_Hz = 3.5;         ///< the fit's input: a 4th-order Butterworth high-pass here
  double amplitude_rate = 0.02;     ///< mu: the WFLC's weights' LMS step (dimensionless; the gate reads it)
  /// The subtracted sine's own LMS step: a second, faster fit at the WFLC's frequency, so that a tremor
  /// that starts or stops is followed within a few of its cycles (the WFLC's slow fit let a stopped
  /// tremor's ghost shake the arm for half a second).
  double tracking_rate = 0.1;
  double frequency_rate = 0.002;    ///< mu0: the frequency's step, normalised by the fitted amplitude
  double gate_on_rad = 0.005;       ///< fitted amplitude where the subtraction starts (0.29 deg)
  double gate_full_rad = 0.012;     ///< ... and is whole (0.69 deg)
};

struct TremorFilterModel {
  TremorFilterParams params;
  ButterworthDesign highpass;        ///< the fit's input filter (sections of a high-pass)
  double min_omega = 0, max_omega = 0, initial_omega = 0;  ///< rad/sample
};

/// The first parameter of `p` no filter can run with, and what it must be (field nullptr: none):
/// frequencies 0 < min < initial < max < Nyquist, highpass below min; rates in (0, 1); 0 <= gate_on <
/// gate_full. A reader names its own key by `field`.
struct TremorFilterProblem {
  const char* field = nullptr;     ///< TremorFilterParams' member name
  const char* expected = nullptr;
};
TremorFilterProblem find_tremor_filter_problem(const TremorFilterParams& p) noexcept;

/// Checks `p` (find_tremor_filter_problem) and designs the high-pass. Throws std::invalid_argument
/// naming the parameter.
TremorFilterModel make_tremor_filter(const TremorFilterParams& p);

struct TremorFilterData {
  SectionState highpass{};          ///< the fit's input filter's state (step_sections)
  double phase = 0, omega = 0;      ///< rad, rad/sample
  double w1 = 0, w2 = 0;            ///< the WFLC's weights (units of the input)
  double v1 = 0, v2 = 0;            ///< the fast fit's weights, at the same phase
  double origin = 0;                ///< the first reading (the high-pass starts at rest there)
  bool started = false;
};

/// A filter at rest (no tremor fitted, omega at the initial frequency). noexcept.
TremorFilterData make_tremor_filter_data(const TremorFilterModel& m) noexcept;

/// Feeds one reading `x` (rad) and returns the voluntary estimate (rad). A non-finite x is returned
/// as it is and changes nothing. noexcept, allocation-free.
double tremor_filter_step(const TremorFilterModel& m, TremorFilterData& d, double x) noexcept;

/// The fitted tremor's frequency, Hz.
double tremor_frequency_Hz(const TremorFilterModel& m, const TremorFilterData& d) noexcept;

}  // namespace peha::control
