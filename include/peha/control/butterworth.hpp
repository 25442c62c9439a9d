#pragma once
/// \file
/// Digital Butterworth low-pass and a filtered derivative (docs/right-arm.md, experiment E4: the elbow
/// goniometer is sampled at 200 Hz, low-passed, differentiated and fed to inverse dynamics).
///
/// Design (the textbook construction, equal to scipy.signal.butter(N, fc, fs=fs)):
/// - analog prototype poles s_k = exp(j pi (2k + N - 1) / (2N)), k = 1..N (unit cut-off);
/// - pre-warping: Omega_c = 2 fs tan(pi fc / fs), so the digital -3 dB point lands exactly at fc;
/// - bilinear transform z = (1 + s/(2 fs)) / (1 - s/(2 fs)) of the poles Omega_c s_k; the N zeros at
///   s = infinity map to z = -1;
/// - gain normalised to 1 at DC (z = 1), section by section.
/// The result is stored as second-order sections (SOS): conjugate pole pairs give biquads, an odd
/// order adds one first-order section for the real pole, stored as a biquad with b2 = a2 = 0.
/// The magnitude is |H(f)|^2 = 1 / (1 + (tan(pi f/fs) / tan(pi fc/fs))^(2N)).
///
/// Model/Data: a `ButterworthDesign` is constant once made; `ButterworthFilter` holds a design and
/// the per-section state. Set-up (design, constructors) throws std::invalid_argument on bad
/// parameters; `step` and `reset` never throw and never allocate.

#include <array>
#include <complex>
#include <vector>

namespace peha::control {

/// Highest Butterworth order peha designs.
inline constexpr int kButterworthMaxOrder = 8;
/// Number of second-order sections of the highest order.
inline constexpr int kButterworthMaxSections = (kButterworthMaxOrder + 1) / 2;

/// One second-order section y/x = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2), a0 = 1.
/// A first-order section has b2 = a2 = 0. Coefficients are dimensionless.
struct SecondOrderSection {
  double b0 = 1.0;  ///< numerator, z^0
  double b1 = 0.0;  ///< numerator, z^-1
  double b2 = 0.0;  ///< numerator, z^-2
  double a1 = 0.0;  ///< denominator, z^-1 (a0 = 1)
  double a2 = 0.0;  ///< denominator, z^-2
};

/// A digital Butterworth low-pass: its parameters, its sections and (for tests and reports) the
/// equivalent direct-form transfer function. Made by `design_butterworth_lowpass`.
struct ButterworthDesign {
  int order = 0;                ///< filter order N, 1..kButterworthMaxOrder
  double cutoff_Hz = 0.0;       ///< -3 dB cut-off frequency fc, Hz
  double sample_rate_Hz = 0.0;  ///< sample rate fs, Hz
  int section_count = 0;        ///< number of used entries of `sections`: (N + 1) / 2
  /// The sections, cascaded in index order: the first-order section (odd N) first, then the
  /// conjugate pairs from the most damped to the least damped pole pair. Each has unity DC gain.
  std::array<SecondOrderSection, kButterworthMaxSections> sections{};
  /// Digital poles z_k (k = 1..N, the order of the analog s_k), all inside the unit circle.
  std::vector<std::complex<double>> poles;
  /// Direct-form numerator b[0..N] (coefficients of z^0..z^-N): the product of the sections'
  /// numerators. For tests and comparisons; the filter itself runs the sections.
  std::vector<double> b;
  /// Direct-form denominator a[0..N] (a[0] = 1): the product of the sections' denominators.
  std::vector<double> a;
};

/// Designs the digital Butterworth low-pass of `order` (1..8) with -3 dB cut-off `cutoff_Hz` at
/// `sample_rate_Hz` (see the file comment). Throws std::invalid_argument unless
/// 1 <= order <= 8, sample_rate_Hz is finite and > 0 and 0 < cutoff_Hz < sample_rate_Hz / 2.
ButterworthDesign design_butterworth_lowpass(int order, double cutoff_Hz, double sample_rate_Hz);

/// Frequency response H(exp(j 2 pi f / fs)) of `design` at `f_Hz` (evaluated from its sections).
/// Dimensionless; |H(0)| = 1, |H(fc)| = 1/sqrt(2). noexcept: a non-finite f gives NaN.
std::complex<double> frequency_response(const ButterworthDesign& design, double f_Hz) noexcept;

/// Group delay -d(phase)/d(omega) of `design` at `f_Hz`, s, computed numerically from the phase
/// (central differences over f +- 1e-3 fc and f +- 0.5e-3 fc, Richardson-extrapolated; equals
/// scipy.signal.group_delay to ~1e-11 relative). For a slow signal (f << fc) this is the
/// time the filtered signal lags the input; at DC it equals the analog prototype's, e.g.
/// sqrt(2) / Omega_c = 37.4 ms for N = 2, fc = 6 Hz, fs = 200 Hz. noexcept.
double group_delay_s(const ButterworthDesign& design, double f_Hz) noexcept;

/// The per-section state of transposed direct form II: {s1, s2} per section.
using SectionState = std::array<std::array<double, 2>, kButterworthMaxSections>;
/// Runs one sample `x` through `design`'s sections (any design: a low-pass, or its mirrored high-pass)
/// in transposed direct form II with `state`; returns the output. noexcept, allocation-free.
double step_sections(const ButterworthDesign& design, SectionState& state, double x) noexcept;

/// A Butterworth low-pass running its design's sections in transposed direct form II.
/// Starts with zero state (the textbook filter: an impulse gives the impulse response); call
/// `reset(x0)` with the first sample to start without a transient.
class ButterworthFilter {
 public:
  /// Runs `design` (as made by design_butterworth_lowpass). Throws std::invalid_argument if the
  /// design has no sections or more than kButterworthMaxSections, a non-finite coefficient, or a
  /// section with a pole at z = 1 (no DC steady state for `reset`).
  explicit ButterworthFilter(ButterworthDesign design);
  /// Designs and runs the low-pass (order, cutoff_Hz, sample_rate_Hz); throws like
  /// design_butterworth_lowpass.
  ButterworthFilter(int order, double cutoff_Hz, double sample_rate_Hz);

  /// Filters one sample `x` (any unit) and returns the output (same unit). noexcept and
  /// allocation-free. A non-finite x poisons the state (NaN out) until the next `reset`.
  double step(double x) noexcept;
  /// Sets the state to the steady state of the constant input `x`: the next steps with input x
  /// output x (to rounding: < 1e-12 relative; no start-up transient). reset(0) is the zero state.
  /// noexcept.
  void reset(double x) noexcept;

  /// Frequency response of the design at `f_Hz` (see the free function).
  std::complex<double> frequency_response(double f_Hz) const noexcept;
  /// Group delay of the design at `f_Hz`, s (see the free function).
  double group_delay_s(double f_Hz) const noexcept;
  /// The design this filter runs.
  const ButterworthDesign& design() const noexcept { return design_; }

 private:
  ButterworthDesign design_;
  /// Transposed-direct-form-II state of each section: {s1, s2}.
  SectionState state_{};
};

/// A Butterworth low-pass followed by backward differences of the filtered signal: the value,
/// rate and acceleration of a noisy sampled signal (E4: the goniometer's elbow angle -> angle,
/// angular velocity and angular acceleration for inverse dynamics).
///
/// With y_k the filter output and fs the sample rate:
///   value        = y_k
///   rate         = (y_k - y_{k-1}) fs                 [input unit / s]
///   acceleration = (y_k - 2 y_{k-1} + y_{k-2}) fs^2   [input unit / s^2]
/// Delays relative to the input, for signals well below fc: the value lags by the filter's group
/// delay tau_g(f); the backward difference is centred half a sample back, so the rate lags by
/// tau_g + 0.5/fs; the second difference is centred one sample back, so the acceleration lags by
/// tau_g + 1/fs (see `value_delay_s`, `rate_delay_s`, `acceleration_delay_s`). The differences'
/// own gain error is (omega/fs)^2/24 (rate) and (omega/fs)^2/12 (acceleration): 1e-5 and 2e-5 at
/// 0.5 Hz, 200 Hz. For a pure sine the exact lag is the phase delay -phase/omega, which differs from
/// the group delay by O((f/fc)^2): 0.17 ms at 0.5 Hz for N = 2, fc = 6 Hz.
///
/// The first `step` after construction starts the filter at its input (as `reset(x)`), so a
/// signal that starts far from zero gives no start-up spike in the rate and acceleration.
/// A non-finite input sample is replaced by the last finite one (counted in
/// `rejected_samples()`), so a single bad sample does not poison the state.
class FilteredDerivative {
 public:
  /// The estimates at one sample. Units: value in the input's unit, rate in unit/s, acceleration
  /// in unit/s^2.
  struct Derivatives {
    double value = 0.0;         ///< filtered signal y_k
    double rate = 0.0;          ///< (y_k - y_{k-1}) fs
    double acceleration = 0.0;  ///< (y_k - 2 y_{k-1} + y_{k-2}) fs^2
  };

  /// Low-pass by `design`; throws like ButterworthFilter(design).
  explicit FilteredDerivative(ButterworthDesign design);
  /// Low-pass (order, cutoff_Hz, sample_rate_Hz); throws like design_butterworth_lowpass.
  FilteredDerivative(int order, double cutoff_Hz, double sample_rate_Hz);

  /// Feeds one sample `x`; returns the estimates. noexcept, allocation-free.
  Derivatives step(double x) noexcept;
  /// Starts at rest at `x`: filter in steady state at x, history y_{k-1} = y_{k-2} = x (rate and
  /// acceleration 0). A non-finite x is replaced by the last finite input (0 before any). noexcept.
  void reset(double x) noexcept;

  /// Group delay of the low-pass at `f_Hz`, s (numerically from its phase).
  double group_delay_s(double f_Hz) const noexcept { return filter_.group_delay_s(f_Hz); }
  /// Lag of `value` behind the input at `f_Hz`, s: the group delay.
  double value_delay_s(double f_Hz) const noexcept { return group_delay_s(f_Hz); }
  /// Lag of `rate` behind the input's derivative at `f_Hz`, s: group delay + 0.5 / fs.
  double rate_delay_s(double f_Hz) const noexcept;
  /// Lag of `acceleration` behind the input's second derivative at `f_Hz`, s: group delay + 1 / fs.
  double acceleration_delay_s(double f_Hz) const noexcept;

  /// The low-pass.
  const ButterworthFilter& filter() const noexcept { return filter_; }
  /// Non-finite samples replaced by the last finite one since construction.
  long rejected_samples() const noexcept { return rejected_samples_; }

 private:
  ButterworthFilter filter_;
  double sample_rate_Hz_;
  double last_input_ = 0.0;
  double y1_ = 0.0;  ///< y_{k-1}
  double y2_ = 0.0;  ///< y_{k-2}
  bool started_ = false;
  long rejected_samples_ = 0;
};

}  // namespace peha::control
