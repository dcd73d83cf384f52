// The feedback loop of a tuned controller (docs/tuning.md): the controller
// C(s) = kp + ki/s + kd·s/(1 + s/(2π·f_d)), the open loop L(s) = C(s)·G(s) with the plant's
// transfer function G (linear_model.h), its stability margins found on the frequency axis,
// and the closed loop's poles, the roots of den_C·den_G + num_C·num_G.
#pragma once

#include <complex>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "blmd/sim/linear_model.h"

namespace blmd {

// C(s) = kp + ki/s + kd·s/(1 + s/(2π·f_d)) in SI units of the loop (position loop of a
// voltage-driven servo: kp V/rad, ki V/(rad·s), kd V·s/rad; speed loop: V·s/rad, V/rad,
// V·s²/rad). derivative_filter_hz = 0 means no filter, and then kd must be 0 (a pure
// derivative is not realisable).
struct Controller {
  double kp = 0.0;
  double ki = 0.0;
  double kd = 0.0;
  double derivative_filter_hz = 0.0;

  // C(jω) at ω rad/s (> 0).
  std::complex<double> At(double omega) const;
  // C(s) = numerator/denominator, descending powers of s (as TransferFunction).
  std::vector<double> Numerator() const;
  std::vector<double> Denominator() const;
};

// p(s) at the complex s, coefficients in descending powers.
std::complex<double> Polyval(const std::vector<double>& coefficients, std::complex<double> s);
// G(jω) of a transfer function.
std::complex<double> FrequencyResponse(const TransferFunction& g, double omega);

// The stability margins of L(jω) = C(jω)·G(jω) (Åström & Murray, Feedback Systems, 2008,
// ch. 9 "Frequency Domain Analysis", stability margins), found on a logarithmic grid of 400 points
// per decade between low_hz and high_hz and refined by bisection to 1e-12 of the frequency:
//  - gain crossovers: |L| = 1. Where there are several, crossover_hz and phase_margin_deg are
//    those of the one nearest −1, the smallest |phase margin| (MATLAB's `allmargin` lists them
//    all): a resonance's peak that crosses 1 again with a margin of −170° has a phase of +10°,
//    far from −1, and is not the worst crossing;
//  - phase margin: 180° + arg L(jω_c), wrapped to (−180°, 180°];
//  - phase crossovers: L(jω) on the negative real axis (Im L = 0, Re L < 0). gain_margin_db
//    is the smallest −20·log10|L| over those with |L| < 1 (how far the gain may rise; +inf
//    when there is none); lower_gain_margin_db the largest over those with |L| > 1 (how far
//    it may fall, negative; −inf when there is none: a conditionally stable loop has one).
struct LoopMargins {
  bool ok = false;
  std::string reason;  // why there are no margins (no gain crossover in the range)
  int gain_crossovers = 0;
  double crossover_hz = std::numeric_limits<double>::quiet_NaN();
  double phase_margin_deg = std::numeric_limits<double>::quiet_NaN();
  double gain_margin_db = std::numeric_limits<double>::infinity();
  double phase_crossover_hz = std::numeric_limits<double>::quiet_NaN();  // of gain_margin_db
  double lower_gain_margin_db = -std::numeric_limits<double>::infinity();
};
LoopMargins ComputeMargins(const TransferFunction& plant, const Controller& controller,
                           double low_hz, double high_hz);
// The same for any open loop given by its frequency response L(ω), ω in rad/s (a sampled
// loop: L(e^{jωTs}), high_hz then below the Nyquist frequency).
LoopMargins ComputeMargins(const std::function<std::complex<double>(double omega)>& loop,
                           double low_hz, double high_hz);

// The closed loop's poles: the roots of den_C·den_G + num_C·num_G (eigenvalues of the
// companion matrix, Eigen). stable: every pole has a negative real part.
struct ClosedLoopPoles {
  std::vector<std::complex<double>> poles;
  bool stable = false;
  // 1/min(−Re p) over the poles, s: the slowest mode's time constant (stable loops).
  double slowest_time_constant = std::numeric_limits<double>::quiet_NaN();
};
ClosedLoopPoles ComputeClosedLoopPoles(const TransferFunction& plant, const Controller& controller);

// Product and sum of polynomials (descending powers).
std::vector<double> PolyMultiply(const std::vector<double>& a, const std::vector<double>& b);
std::vector<double> PolyAdd(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace blmd
