#include "peha/control/butterworth.hpp"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace peha::control {
namespace {

using Complex = std::complex<double>;

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("Butterworth low-pass: " + what);
}

std::string number(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

void validate(int order, double cutoff_Hz, double sample_rate_Hz) {
  if (order < 1 || order > kButterworthMaxOrder) {
    fail("order must be in 1.." + std::to_string(kButterworthMaxOrder) + ", got " + std::to_string(order));
  }
  if (!std::isfinite(sample_rate_Hz) || sample_rate_Hz <= 0.0) {
    fail("sample_rate_Hz must be finite and > 0, got " + number(sample_rate_Hz));
  }
  if (!std::isfinite(cutoff_Hz) || cutoff_Hz <= 0.0 || cutoff_Hz >= 0.5 * sample_rate_Hz) {
    fail("cutoff_Hz must satisfy 0 < cutoff_Hz < sample_rate_Hz / 2 = " + number(0.5 * sample_rate_Hz) +
         " Hz (Nyquist), got " + number(cutoff_Hz));
  }
}

/// Product of two polynomials in z^-1 (coefficient i multiplies z^-i).
std::vector<double> multiply(const std::vector<double>& p, const std::vector<double>& q) {
  std::vector<double> r(p.size() + q.size() - 1, 0.0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::size_t j = 0; j < q.size(); ++j) r[i + j] += p[i] * q[j];
  }
  return r;
}

Complex section_response(const SecondOrderSection& s, Complex w) noexcept {  // w = z^-1
  const Complex num = s.b0 + w * (s.b1 + w * s.b2);
  const Complex den = 1.0 + w * (s.a1 + w * s.a2);
  return num / den;
}

}  // namespace

ButterworthDesign design_butterworth_lowpass(int order, double cutoff_Hz, double sample_rate_Hz) {
  validate(order, cutoff_Hz, sample_rate_Hz);
  const double pi = std::numbers::pi;
  const int n = order;
  const double two_fs = 2.0 * sample_rate_Hz;
  const double omega_c = two_fs * std::tan(pi * cutoff_Hz / sample_rate_Hz);  // pre-warped, rad/s

  ButterworthDesign d;
  d.order = n;
  d.cutoff_Hz = cutoff_Hz;
  d.sample_rate_Hz = sample_rate_Hz;
  d.section_count = (n + 1) / 2;

  // Analog prototype poles s_k (left half plane) and their bilinear images z_k.
  auto digital_pole = [&](int k) {
    const Complex s_k = std::polar(1.0, pi * (2.0 * k + n - 1) / (2.0 * n));
    const Complex p = omega_c * s_k / two_fs;  // s / (2 fs)
    return (1.0 + p) / (1.0 - p);
  };
  d.poles.reserve(static_cast<std::size_t>(n));
  for (int k = 1; k <= n; ++k) d.poles.push_back(digital_pole(k));

  int next = 0;
  if (n % 2 == 1) {
    // Real pole s = -Omega_c (k = (N + 1) / 2): H = g (1 + z^-1) / (1 - z_r z^-1), g = (1 - z_r) / 2.
    const double z_r = d.poles[static_cast<std::size_t>((n + 1) / 2 - 1)].real();
    SecondOrderSection s;
    s.a1 = -z_r;
    s.a2 = 0.0;
    const double g = 0.5 * (1.0 + s.a1);
    s.b0 = g;
    s.b1 = g;
    s.b2 = 0.0;
    d.sections[static_cast<std::size_t>(next++)] = s;
  }
  // Conjugate pairs (s_k, s_{N+1-k}), k = 1..N/2. k = N/2 is the most damped pair (furthest from
  // the imaginary axis), k = 1 the least damped: cascade from k = N/2 down to k = 1.
  for (int k = n / 2; k >= 1; --k) {
    const Complex z = d.poles[static_cast<std::size_t>(k - 1)];
    SecondOrderSection s;
    s.a1 = -2.0 * z.real();
    s.a2 = std::norm(z);
    const double g = 0.25 * (1.0 + s.a1 + s.a2);  // zeros (1 + z^-1)^2 have gain 4 at DC
    s.b0 = g;
    s.b1 = 2.0 * g;
    s.b2 = g;
    d.sections[static_cast<std::size_t>(next++)] = s;
  }

  std::vector<double> b{1.0}, a{1.0};
  for (int i = 0; i < d.section_count; ++i) {
    const SecondOrderSection& s = d.sections[static_cast<std::size_t>(i)];
    b = multiply(b, {s.b0, s.b1, s.b2});
    a = multiply(a, {1.0, s.a1, s.a2});
  }
  b.resize(static_cast<std::size_t>(n + 1));  // odd N: drop the first-order section's zero tail
  a.resize(static_cast<std::size_t>(n + 1));
  d.b = std::move(b);
  d.a = std::move(a);
  return d;
}

std::complex<double> frequency_response(const ButterworthDesign& design, double f_Hz) noexcept {
  const double theta = 2.0 * std::numbers::pi * f_Hz / design.sample_rate_Hz;
  const Complex w = std::polar(1.0, -theta);
  Complex h = 1.0;
  for (int i = 0; i < design.section_count; ++i) h *= section_response(design.sections[static_cast<std::size_t>(i)], w);
  return h;
}

double group_delay_s(const ButterworthDesign& design, double f_Hz) noexcept {
  // tau = -d phi / d omega, phi the phase of H, omega = 2 pi f. Central differences of the phase,
  // each taken as arg(H(f+h) / H(f-h)) (no unwrapping needed while the phase moves < pi across the
  // interval), combined by Richardson extrapolation: error O(h^4). h = 1e-3 fc keeps the phase step
  // ~0.01 rad at any order and cut-off, so truncation (~1e-12) and rounding (~1e-13) stay small.
  double h_Hz = 1e-3 * design.cutoff_Hz;
  if (!(h_Hz > 0.0) || !std::isfinite(h_Hz)) h_Hz = 1e-5 * design.sample_rate_Hz;  // hand-made design
  auto central = [&](double h) {
    const Complex ratio = frequency_response(design, f_Hz + h) / frequency_response(design, f_Hz - h);
    return -std::arg(ratio) / (2.0 * std::numbers::pi * 2.0 * h);
  };
  return (4.0 * central(0.5 * h_Hz) - central(h_Hz)) / 3.0;
}

ButterworthFilter::ButterworthFilter(ButterworthDesign design) : design_(std::move(design)) {
  if (design_.section_count < 1 || design_.section_count > kButterworthMaxSections) {
    fail("a design needs 1.." + std::to_string(kButterworthMaxSections) + " sections, got " +
         std::to_string(design_.section_count) + " (make it with design_butterworth_lowpass)");
  }
  for (int i = 0; i < design_.section_count; ++i) {
    const SecondOrderSection& s = design_.sections[static_cast<std::size_t>(i)];
    for (double c : {s.b0, s.b1, s.b2, s.a1, s.a2}) {
      if (!std::isfinite(c)) fail("section " + std::to_string(i) + " has a non-finite coefficient");
    }
    if (std::abs(1.0 + s.a1 + s.a2) < 1e-300) fail("section " + std::to_string(i) + " has a pole at z = 1");
  }
}

ButterworthFilter::ButterworthFilter(int order, double cutoff_Hz, double sample_rate_Hz)
    : ButterworthFilter(design_butterworth_lowpass(order, cutoff_Hz, sample_rate_Hz)) {}

double step_sections(const ButterworthDesign& design, SectionState& state, double x) noexcept {
  double u = x;
  for (int i = 0; i < design.section_count; ++i) {
    const SecondOrderSection& s = design.sections[static_cast<std::size_t>(i)];
    std::array<double, 2>& z = state[static_cast<std::size_t>(i)];
    const double y = s.b0 * u + z[0];
    z[0] = s.b1 * u - s.a1 * y + z[1];
    z[1] = s.b2 * u - s.a2 * y;
    u = y;
  }
  return u;
}

double ButterworthFilter::step(double x) noexcept { return step_sections(design_, state_, x); }

void ButterworthFilter::reset(double x) noexcept {
  // Steady state of a section with constant input u and output y = G u (G its DC gain, 1 for a
  // Butterworth section): s2 = b2 u - a2 y, s1 = b1 u - a1 y + s2. The next section sees y.
  double u = x;
  for (int i = 0; i < design_.section_count; ++i) {
    const SecondOrderSection& s = design_.sections[static_cast<std::size_t>(i)];
    const double gain = (s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2);
    const double y = gain * u;
    std::array<double, 2>& z = state_[static_cast<std::size_t>(i)];
    z[1] = s.b2 * u - s.a2 * y;
    z[0] = s.b1 * u - s.a1 * y + z[1];
    u = y;
  }
}

std::complex<double> ButterworthFilter::frequency_response(double f_Hz) const noexcept {
  return control::frequency_response(design_, f_Hz);
}

double ButterworthFilter::group_delay_s(double f_Hz) const noexcept {
  return control::group_delay_s(design_, f_Hz);
}

FilteredDerivative::FilteredDerivative(ButterworthDesign design)
    : filter_(std::move(design)), sample_rate_Hz_(filter_.design().sample_rate_Hz) {
  if (!std::isfinite(sample_rate_Hz_) || sample_rate_Hz_ <= 0.0) {
    fail("FilteredDerivative needs a finite sample rate > 0, got " + number(sample_rate_Hz_));
  }
}

FilteredDerivative::FilteredDerivative(int order, double cutoff_Hz, double sample_rate_Hz)
    : FilteredDerivative(design_butterworth_lowpass(order, cutoff_Hz, sample_rate_Hz)) {}

FilteredDerivative::Derivatives FilteredDerivative::step(double x) noexcept {
  if (!std::isfinite(x)) {
    ++rejected_samples_;
    x = last_input_;  // 0 if no finite sample came yet
  }
  last_input_ = x;
  if (!started_) reset(x);
  const double y = filter_.step(x);
  Derivatives out;
  out.value = y;
  out.rate = (y - y1_) * sample_rate_Hz_;
  out.acceleration = (y - 2.0 * y1_ + y2_) * sample_rate_Hz_ * sample_rate_Hz_;
  y2_ = y1_;
  y1_ = y;
  return out;
}

void FilteredDerivative::reset(double x) noexcept {
  if (!std::isfinite(x)) x = last_input_;  // never start from NaN/inf
  filter_.reset(x);
  y1_ = x;
  y2_ = x;
  last_input_ = x;
  started_ = true;
}

double FilteredDerivative::rate_delay_s(double f_Hz) const noexcept {
  return group_delay_s(f_Hz) + 0.5 / sample_rate_Hz_;
}

double FilteredDerivative::acceleration_delay_s(double f_Hz) const noexcept {
  return group_delay_s(f_Hz) + 1.0 / sample_rate_Hz_;
}

}  // namespace peha::control
