// Equation error: the inverse dynamic identification model (IDIM) of rigid_load
// (docs/identification.md §8). Instead of simulating the model from the recorded input and
// comparing its motion with the measured one (output error), the model's equation is
// evaluated along the measured motion and the input it needs is compared with the recorded
// input:
//
//   u_model(k) = (J a(k) + B w(k) + T_effects(theta(k), w(k))) / Kt      (rigid_load, eq. 1)
//   e(k)       = u_model(k) - u(k)                                       (input units)
//
// with w and a the first and second central differences of the measured position after a
// zero-phase Butterworth low-pass F (order 4, applied forwards and backwards), as the EMPS
// benchmark's IDIM-LS (Janot, Gautier & Brunot 2019, §3; Gautier 1997). The recorded input
// and the effects' torque pass F too, so both sides of the equation are filtered alike:
//   F(u) = J F(a) + B F(w) + F(T_effects)   (F commutes with d/dt, J and B; the effects are
// evaluated at the filtered motion, then filtered). With decimation by
// N, the recorded input and the model's input both pass the same zero-phase anti-alias
// filter (Chebyshev type I, order 8, 0.05 dB ripple, cut-off 0.8 of the new Nyquist rate,
// as MATLAB's `decimate`) before every N-th sample is kept: "parallel filtering", so the
// filter cannot bias the parameters. The cost is then linear least squares in every
// parameter that enters linearly (J, B, Tc, TL, dB, Cd) and needs no simulation: an
// integrating, closed-loop rig whose simulated motion drifts from the recorded one can
// still be fitted, at the price of a bias from the noise in the differentiated motion.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "blmd/sim/biquad.h"
#include "blmd/sim/parameters.h"
#include "blmd/sim/trace.h"

namespace blmd {

struct FitTrace;
struct IdentificationSettings;

// Digital low-pass filters by the bilinear transform with a pre-warped cut-off, as cascades
// of second-order sections (even orders). Butterworth: -3 dB at cutoff_hz. Chebyshev type
// I: the pass band ripples by ripple_db and ends at cutoff_hz; DC gain 10^(-ripple_db/20)
// (even order), as scipy.signal.cheby1 and MATLAB's cheby1.
std::vector<Biquad> ButterworthLowPass(int order, double cutoff_hz, double sample_hz);
std::vector<Biquad> ChebyshevLowPass(int order, double ripple_db, double cutoff_hz,
                                     double sample_hz);

// Zero-phase filtering: the sections forwards, then backwards over the result. Each end is
// extended by its odd reflection and each pass starts from the steady state of its first
// value (as scipy's sosfiltfilt), the extension long enough for the start's transient to
// decay by 1e-12 (FiltFiltSettling, at most the signal's length less one): a constant and
// a ramp come out unchanged, and so does a signal that ends in a straight line (a shaft
// turning steadily when the record ends). `x` must be longer than FiltFiltPadding.
std::vector<double> FiltFilt(const std::vector<Biquad>& sections, const std::vector<double>& x);
// The shortest extension, 3 (2 sections + 1) samples (scipy's default).
std::size_t FiltFiltPadding(const std::vector<Biquad>& sections);
// Samples for the slowest pole to decay by 1e-12.
std::size_t FiltFiltSettling(const std::vector<Biquad>& sections);

// A trace prepared for the equation error: the filtered motion at full rate (every sample
// but the first and the last, which have no central difference) and what the cost compares.
struct EquationTrace {
  std::vector<double> t, theta, w, a;  // s, rad (m), rad/s (m/s), rad/s^2 (m/s^2)
  std::vector<Biquad> motion_filter;   // the Butterworth low-pass of the motion and the input
  std::vector<Biquad> anti_alias;      // empty without decimation
  int decimate = 1;
  double cutoff_hz = 0.0;  // the motion filter's cut-off in use
  // The recorded input through the motion's filter, at full rate (as t, w, a), and the
  // samples at rest: runs of at least 0.1 s where the filtered speed stays within 2 % of its
  // largest; there a friction is static, the torque that balances the drive up to its
  // breakaway torque (Karnopp 1985), not the sign of a speed that dithers about zero.
  std::vector<double> u;
  std::vector<char> at_rest;
  std::size_t rest_samples = 0;
  // At the kept samples: t, u (the recorded input, anti-alias filtered), and the filtered
  // w and theta, for reports and plots.
  Trace measured;
};

// Prepares a trace (its theta column, else its w column, is the measured motion); throws
// InputError naming the file for uneven time steps, a cut-off at or above half the
// sampling rate, or too few samples for the filters.
EquationTrace PrepareEquationTrace(const FitTrace& trace, const IdentificationSettings& settings);

// The input the model needs along the measured motion, at the kept samples: columns t, u
// (the model's), w and theta (measured, as in `measured`). `effects`: the enabled effects.
void PredictInput(const EquationTrace& trace, const ParameterSet& parameters,
                  const std::vector<std::string>& effects, Trace* out);

}  // namespace blmd
