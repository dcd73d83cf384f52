#include "blmd/ident/fit/equation_error.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/sim/effects.h"
#include "ident/fit/rest_runs.h"

namespace blmd {
namespace {

// The section of one analog pole pair (s, conj s) by the bilinear transform at sample_hz,
// with its two zeros at z = -1 (a low-pass's zeros at infinity) and unit gain at DC.
Biquad BilinearSection(std::complex<double> s, double sample_hz) {
  const double k = 2.0 * sample_hz;
  const std::complex<double> z = (k + s) / (k - s);
  Biquad section;
  section.a1 = -2.0 * z.real();
  section.a2 = std::norm(z);
  const double gain = (1.0 + section.a1 + section.a2) / 4.0;
  section.b0 = gain;
  section.b1 = 2.0 * gain;
  section.b2 = gain;
  return section;
}

// The samples at rest (docs/identification.md §8b): runs of at least 0.1 s and 20 samples over
// which the filtered speed stays within 0.5 % of its largest magnitude. A held shaft dithers
// between encoder counts, so its differentiated speed changes sign under any change of the
// data; over such a run the friction is static.
std::vector<char> RestSamples(const std::vector<double>& t, const std::vector<double>& w) {
  std::vector<char> rest(w.size(), 0);
  double top = 0.0;
  for (double v : w) top = std::max(top, std::abs(v));
  if (!(top > 0.0)) return rest;
  for (const auto& [begin, end] : internal::RestRuns(t, w, 0.005 * top)) {
    std::fill(rest.begin() + static_cast<long>(begin), rest.begin() + static_cast<long>(end), 1);
  }
  return rest;
}

// Pre-warped analog cut-off (rad/s) of a digital cut-off at cutoff_hz.
double Prewarp(double cutoff_hz, double sample_hz) {
  return 2.0 * sample_hz * std::tan(kPi * cutoff_hz / sample_hz);
}

void CheckDesign(int order, double cutoff_hz, double sample_hz) {
  if (order < 2 || order % 2 != 0 || !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_hz)) {
    throw InputError("low-pass filter: need an even order >= 2 and 0 < cut-off " +
                     FormatSignificant(cutoff_hz, 6) + " Hz < half the sampling rate " +
                     FormatSignificant(0.5 * sample_hz, 6) + " Hz");
  }
}

// Steady state of a section's transposed direct form II for a constant input x0.
void SteadyState(const Biquad& s, double x0, double* z1, double* z2) {
  const double gain = (s.b0 + s.b1 + s.b2) / (1.0 + s.a1 + s.a2);
  *z2 = (s.b2 - s.a2 * gain) * x0;
  *z1 = (gain - s.b0) * x0;
}

// The sections over x in place, each from the steady state of x's first value.
void FilterInPlace(const std::vector<Biquad>& sections, std::vector<double>* x) {
  for (const Biquad& s : sections) {
    double z1 = 0.0, z2 = 0.0;
    SteadyState(s, x->front(), &z1, &z2);
    for (double& v : *x) {
      const double y = s.b0 * v + z1;
      z1 = s.b1 * v - s.a1 * y + z2;
      z2 = s.b2 * v - s.a2 * y;
      v = y;
    }
  }
}

}  // namespace

std::vector<Biquad> ButterworthLowPass(int order, double cutoff_hz, double sample_hz) {
  CheckDesign(order, cutoff_hz, sample_hz);
  const double wa = Prewarp(cutoff_hz, sample_hz);
  std::vector<Biquad> sections;
  for (int k = 1; k <= order / 2; ++k) {
    // Upper-half-plane poles of the normalised Butterworth prototype.
    const double angle = kPi * (2.0 * k + order - 1.0) / (2.0 * order);
    sections.push_back(BilinearSection(wa * std::polar(1.0, angle), sample_hz));
  }
  return sections;
}

std::vector<Biquad> ChebyshevLowPass(int order, double ripple_db, double cutoff_hz,
                                     double sample_hz) {
  CheckDesign(order, cutoff_hz, sample_hz);
  if (!(ripple_db > 0.0)) throw InputError("Chebyshev low-pass: the ripple must be positive");
  const double wa = Prewarp(cutoff_hz, sample_hz);
  const double epsilon = std::sqrt(std::pow(10.0, ripple_db / 10.0) - 1.0);
  const double mu = std::asinh(1.0 / epsilon) / order;
  std::vector<Biquad> sections;
  for (int k = 1; k <= order / 2; ++k) {
    const double theta = kPi * (2.0 * k - 1.0) / (2.0 * order);
    const std::complex<double> pole(-std::sinh(mu) * std::sin(theta),
                                    std::cosh(mu) * std::cos(theta));
    sections.push_back(BilinearSection(wa * pole, sample_hz));
  }
  // Even order: the DC gain sits at the bottom of the ripple.
  const double dc = std::pow(10.0, -ripple_db / 20.0);
  sections.front().b0 *= dc;
  sections.front().b1 *= dc;
  sections.front().b2 *= dc;
  return sections;
}

std::size_t FiltFiltPadding(const std::vector<Biquad>& sections) {
  return 3 * (2 * sections.size() + 1);
}

std::size_t FiltFiltSettling(const std::vector<Biquad>& sections) {
  // The slowest pole's radius: |z|^2 = a2 for a complex pair, else the larger real root.
  double radius = 0.0;
  for (const Biquad& s : sections) {
    const double discriminant = s.a1 * s.a1 - 4.0 * s.a2;
    radius =
        std::max(radius, discriminant < 0.0 ? std::sqrt(s.a2)
                                            : 0.5 * (std::abs(s.a1) + std::sqrt(discriminant)));
  }
  if (!(radius > 0.0)) return 0;
  if (!(radius < 1.0)) return std::numeric_limits<std::size_t>::max();
  return static_cast<std::size_t>(std::ceil(std::log(1e-12) / std::log(radius)));
}

std::vector<double> FiltFilt(const std::vector<Biquad>& sections, const std::vector<double>& x) {
  const std::size_t n = x.size(), minimum = FiltFiltPadding(sections);
  if (n <= minimum)
    throw InputError("zero-phase filter: " + std::to_string(n) + " samples, need more than " +
                     std::to_string(minimum));
  const std::size_t pad = std::min(n - 1, std::max(minimum, FiltFiltSettling(sections)));
  std::vector<double> y;
  y.reserve(n + 2 * pad);
  for (std::size_t k = pad; k >= 1; --k) y.push_back(2.0 * x.front() - x[k]);
  y.insert(y.end(), x.begin(), x.end());
  for (std::size_t k = 1; k <= pad; ++k) y.push_back(2.0 * x.back() - x[n - 1 - k]);
  FilterInPlace(sections, &y);
  std::reverse(y.begin(), y.end());
  FilterInPlace(sections, &y);
  std::reverse(y.begin(), y.end());
  return std::vector<double>(y.begin() + static_cast<long>(pad),
                             y.begin() + static_cast<long>(pad + n));
}

EquationTrace PrepareEquationTrace(const FitTrace& fit_trace,
                                   const IdentificationSettings& settings) {
  const Trace& trace = fit_trace.trace;
  const std::string where = fit_trace.path.empty() ? "trace" : fit_trace.path;
  const bool has_theta = trace.Has("theta");
  if (!has_theta && !trace.Has("w")) {
    throw InputError(where +
                     ": the equation error needs the measured motion: a theta or w "
                     "column (--column theta=HEADER or --column w=HEADER)");
  }
  const auto& t = trace.Column("t");
  const auto& u = trace.Column("u");
  const auto& motion = trace.Column(has_theta ? "theta" : "w");
  const std::size_t n = t.size();
  if (n < 5) {
    throw InputError(where + ": " + std::to_string(n) +
                     " samples: too few for the equation error's differences");
  }
  std::vector<double> steps(n - 1);
  for (std::size_t k = 1; k < n; ++k) steps[k - 1] = t[k] - t[k - 1];
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double dt = sorted[sorted.size() / 2];
  const auto [lo, hi] = std::minmax_element(steps.begin(), steps.end());
  if (!(dt > 0.0) || *hi - dt > 0.01 * dt || dt - *lo > 0.01 * dt) {
    throw InputError(where +
                     ": the equation error filters the samples, which must be evenly "
                     "spaced; the time step varies from " +
                     FormatSignificant(*lo, 6) + " to " + FormatSignificant(*hi, 6) +
                     " s: interpolate it onto a uniform grid with --resample auto (the median "
                     "step, " +
                     FormatSignificant(dt, 6) + " s)");
  }
  const double sample_hz = 1.0 / dt;
  const double cutoff_hz = settings.filter_hz > 0.0 ? settings.filter_hz : 0.1 * sample_hz;
  if (!(cutoff_hz < 0.5 * sample_hz)) {
    throw InputError(where + ": filter_hz " + FormatSignificant(cutoff_hz, 6) +
                     " Hz is not below half the sampling rate (" +
                     FormatSignificant(0.5 * sample_hz, 6) + " Hz)");
  }
  const std::vector<Biquad> motion_filter = ButterworthLowPass(4, cutoff_hz, sample_hz);
  EquationTrace out;
  out.motion_filter = motion_filter;
  out.decimate = std::max(1, settings.decimate);
  out.cutoff_hz = cutoff_hz;
  if (out.decimate > 1) {
    out.anti_alias = ChebyshevLowPass(8, 0.05, 0.8 * 0.5 * sample_hz / out.decimate, sample_hz);
  }
  const std::size_t needed =
      std::max(FiltFiltPadding(motion_filter), FiltFiltPadding(out.anti_alias)) + 3;
  if (n < needed || (n - 2) / static_cast<std::size_t>(out.decimate) < 10) {
    throw InputError(where + ": " + std::to_string(n) +
                     " samples: too few for the equation "
                     "error's filters (need " +
                     std::to_string(needed) + " and 10 after decimating by " +
                     std::to_string(out.decimate) + ")");
  }
  const std::vector<double> filtered = FiltFilt(motion_filter, motion);
  // Central differences at samples 1 .. n-2 (second order on a non-uniform grid too).
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const double h_back = t[k] - t[k - 1], h_fwd = t[k + 1] - t[k];
    const double slope_back = (filtered[k] - filtered[k - 1]) / h_back;
    const double slope_fwd = (filtered[k + 1] - filtered[k]) / h_fwd;
    out.t.push_back(t[k]);
    if (has_theta) {
      out.theta.push_back(filtered[k]);
      out.w.push_back((filtered[k + 1] - filtered[k - 1]) / (h_back + h_fwd));
      out.a.push_back(2.0 * (slope_fwd - slope_back) / (h_back + h_fwd));
    } else {
      out.w.push_back(filtered[k]);
      out.a.push_back((filtered[k + 1] - filtered[k - 1]) / (h_back + h_fwd));
    }
  }
  if (!has_theta) {
    // The angle (cogging) by the trapezoidal rule from the trace's initial angle.
    out.theta.assign(out.w.size(), fit_trace.initial.theta);
    for (std::size_t j = 1; j < out.w.size(); ++j) {
      out.theta[j] = out.theta[j - 1] + 0.5 * (out.w[j] + out.w[j - 1]) * (out.t[j] - out.t[j - 1]);
    }
  }
  // The recorded input passes the motion's filter too ("parallel filtering"): filtering
  // commutes with J d/dt and B, so the filter cannot bias J and B.
  const std::vector<double> filtered_input = FiltFilt(motion_filter, u);
  std::vector<double> input(filtered_input.begin() + 1, filtered_input.end() - 1);
  out.u = input;
  out.at_rest = RestSamples(out.t, out.w);
  for (char rest : out.at_rest) out.rest_samples += rest ? 1 : 0;
  if (!out.anti_alias.empty()) input = FiltFilt(out.anti_alias, input);
  std::vector<double> kept_t, kept_u, kept_w, kept_theta;
  for (std::size_t j = 0; j < out.t.size(); j += static_cast<std::size_t>(out.decimate)) {
    kept_t.push_back(out.t[j]);
    kept_u.push_back(input[j]);
    kept_w.push_back(out.w[j]);
    kept_theta.push_back(out.theta[j]);
  }
  out.measured.Set("t", std::move(kept_t));
  out.measured.Set("u", std::move(kept_u));
  out.measured.Set("w", std::move(kept_w));
  out.measured.Set("theta", std::move(kept_theta));
  return out;
}

void PredictInput(const EquationTrace& trace, const ParameterSet& parameters,
                  const std::vector<std::string>& effects, Trace* out) {
  const double J = parameters.Get("J"), B = parameters.Get("B"), Kt = parameters.Get("Kt");
  const ShaftEffects shaft = ShaftEffects::From(parameters, effects, 0.0);
  const bool friction = shaft.has_friction();
  const std::size_t n = trace.t.size();
  std::vector<double> input(n);
  if (!effects.empty()) {
    // T_effects at the filtered motion, then through the motion's filter (as u was).
    std::vector<double> torque(n);
    for (std::size_t j = 0; j < n; ++j) {
      const double w = trace.w[j];
      torque[j] = shaft.NonFrictionTorque(trace.theta[j]) + shaft.DragTorque(w);
      if (friction && !trace.at_rest.empty() && trace.at_rest[j]) {
        // At rest friction is static: whatever balances the drive, up to its breakaway
        // torque (Karnopp's zero-velocity band), not a sign of a speed that dithers.
        const double applied = Kt * trace.u[j] - torque[j] - J * trace.a[j] - B * w;
        const double breakaway = shaft.FrictionMagnitude(0.0);
        torque[j] += std::clamp(applied, -breakaway, breakaway);
      } else if (friction && w != 0.0) {
        torque[j] += w > 0.0 ? shaft.FrictionMagnitude(w) : -shaft.FrictionMagnitude(w);
      }
    }
    input = FiltFilt(trace.motion_filter, torque);
  }
  for (std::size_t j = 0; j < n; ++j) input[j] = (input[j] + J * trace.a[j] + B * trace.w[j]) / Kt;
  if (!trace.anti_alias.empty()) input = FiltFilt(trace.anti_alias, input);
  std::vector<double> kept;
  kept.reserve(trace.measured.rows());
  for (std::size_t j = 0; j < input.size(); j += static_cast<std::size_t>(trace.decimate)) {
    kept.push_back(input[j]);
  }
  *out = Trace();
  out->Set("t", trace.measured.Column("t"));
  out->Set("u", std::move(kept));
  out->Set("w", trace.measured.Column("w"));
  out->Set("theta", trace.measured.Column("theta"));
}

}  // namespace blmd
