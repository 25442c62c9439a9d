#include "peha/control/tremor_filter.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace peha::control {
namespace {

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("tremor filter: " + what); }

/// A Butterworth high-pass at `cutoff_Hz`: the low-pass at fs/2 - cutoff with z^-1 -> -z^-1, which
/// mirrors its response about fs/4 (the low-pass's cut-off lands at `cutoff_Hz`, its DC at Nyquist).
ButterworthDesign highpass(int order, double cutoff_Hz, double fs_Hz) {
  ButterworthDesign d = design_butterworth_lowpass(order, 0.5 * fs_Hz - cutoff_Hz, fs_Hz);
  for (int i = 0; i < d.section_count; ++i) {
    SecondOrderSection& s = d.sections[static_cast<std::size_t>(i)];
    s.b1 = -s.b1;
    s.a1 = -s.a1;
  }
  d.cutoff_Hz = cutoff_Hz;
  d.poles.clear();  // the low-pass's; the sections are what runs
  d.b.clear();
  d.a.clear();
  return d;
}

}  // namespace

TremorFilterProblem find_tremor_filter_problem(const TremorFilterParams& p) noexcept {
  const double nyquist = 0.5 * p.sample_rate_Hz;
  if (!(std::isfinite(p.sample_rate_Hz) && p.sample_rate_Hz > 0)) return {"sample_rate_Hz", "expected a finite rate > 0"};
  if (!(p.min_frequency_Hz > 0 && p.min_frequency_Hz < p.initial_frequency_Hz && p.initial_frequency_Hz < p.max_frequency_Hz &&
        p.max_frequency_Hz < nyquist)) {
    return {"min_frequency_Hz", "expected 0 < min_frequency_Hz < initial_frequency_Hz < max_frequency_Hz < the Nyquist frequency"};
  }
  if (!(p.highpass_Hz > 0 && p.highpass_Hz < p.min_frequency_Hz)) return {"highpass_Hz", "expected in (0, min_frequency_Hz)"};
  if (!(p.amplitude_rate > 0 && p.amplitude_rate < 1)) return {"amplitude_rate", "expected in (0, 1)"};
  if (!(p.frequency_rate > 0 && p.frequency_rate < 1)) return {"frequency_rate", "expected in (0, 1)"};
  if (!(p.tracking_rate > 0 && p.tracking_rate < 1)) return {"tracking_rate", "expected in (0, 1)"};
  if (!(p.gate_on_rad >= 0 && p.gate_full_rad > p.gate_on_rad && std::isfinite(p.gate_full_rad))) {
    return {"gate_full_rad", "expected 0 <= gate_on < gate_full"};
  }
  return {};
}

TremorFilterModel make_tremor_filter(const TremorFilterParams& p) {
  if (const TremorFilterProblem problem = find_tremor_filter_problem(p); problem.field) {
    fail(std::string(problem.field) + ": " + problem.expected);
  }
  TremorFilterModel m;
  m.params = p;
  m.highpass = highpass(4, p.highpass_Hz, p.sample_rate_Hz);
  const double per_sample = 2.0 * std::numbers::pi / p.sample_rate_Hz;
  m.min_omega = p.min_frequency_Hz * per_sample;
  m.max_omega = p.max_frequency_Hz * per_sample;
  m.initial_omega = p.initial_frequency_Hz * per_sample;
  return m;
}

TremorFilterData make_tremor_filter_data(const TremorFilterModel& m) noexcept {
  TremorFilterData d;
  d.omega = m.initial_omega;
  return d;
}

double tremor_filter_step(const TremorFilterModel& m, TremorFilterData& d, double x) noexcept {
  if (!std::isfinite(x)) return x;
  if (!d.started) {  // the high-pass at rest at the first reading
    d.started = true;
    d.origin = x;
  }
  const TremorFilterParams& p = m.params;
  const double s = step_sections(m.highpass, d.highpass, x - d.origin);
  const double x1 = std::sin(d.phase), x2 = std::cos(d.phase);
  const double e = s - (d.w1 * x1 + d.w2 * x2);
  // The frequency's step normalised by the fitted power (a0 keeps it bounded with no tremor yet).
  const double a0 = p.gate_on_rad;
  const double power = d.w1 * d.w1 + d.w2 * d.w2 + a0 * a0;
  d.omega = std::clamp(d.omega + 2.0 * p.frequency_rate * e * (d.w1 * x2 - d.w2 * x1) / power, m.min_omega, m.max_omega);
  d.w1 += 2.0 * p.amplitude_rate * e * x1;
  d.w2 += 2.0 * p.amplitude_rate * e * x2;
  const double e_fast = s - (d.v1 * x1 + d.v2 * x2);
  d.v1 += 2.0 * p.tracking_rate * e_fast * x1;
  d.v2 += 2.0 * p.tracking_rate * e_fast * x2;
  // The fits are of the high-passed tremor: back to the reading's by 1 / H at the fitted frequency.
  const double f_Hz = d.omega * p.sample_rate_Hz / (2.0 * std::numbers::pi);
  const std::complex<double> h = frequency_response(m.highpass, f_Hz);
  const std::complex<double> raw = std::complex<double>(d.v2, -d.v1) / h;  // v1 sin + v2 cos = Re{(v2 - j v1) e^{j phi}}
  const double amplitude = std::hypot(d.w1, d.w2);
  const double gate = std::clamp((amplitude - p.gate_on_rad) / (p.gate_full_rad - p.gate_on_rad), 0.0, 1.0);
  const double tremor = gate * (raw * std::polar(1.0, d.phase)).real();
  d.phase = std::remainder(d.phase + d.omega, 2.0 * std::numbers::pi);
  return x - tremor;
}

double tremor_frequency_Hz(const TremorFilterModel& m, const TremorFilterData& d) noexcept {
  return d.omega * m.params.sample_rate_Hz / (2.0 * std::numbers::pi);
}

}  // namespace peha::control
