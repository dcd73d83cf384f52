#include "blmd/sim/notch_filter.h"

#include <cmath>

#include "blmd/constants.h"
#include "blmd/format.h"

namespace blmd {

std::string NotchFilter::Validate(double sample_rate_hz) const {
  if (!(frequency > 0.0) || !std::isfinite(frequency)) return "the notch frequency must be > 0 Hz";
  if (!(frequency < 0.5 * sample_rate_hz)) {
    return "the notch frequency " + DisplayNumber(frequency) +
           " Hz must be below the Nyquist frequency of the controller's sampling (" +
           DisplayNumber(0.5 * sample_rate_hz) + " Hz)";
  }
  if (!(width > 0.0) || !std::isfinite(width)) return "the notch width must be > 0 Hz";
  if (!(depth >= 0.0 && depth < 1.0)) {
    return "the notch depth (its gain at the centre) must be in [0, 1)";
  }
  return "";
}

std::complex<double> NotchFilter::ContinuousAt(std::complex<double> s) const {
  if (!active()) return 1.0;
  const double wn = kTwoPi * frequency, zp = width / (2.0 * frequency), zz = depth * zp;
  return (s * s + 2.0 * zz * wn * s + wn * wn) / (s * s + 2.0 * zp * wn * s + wn * wn);
}

// s = K (z − 1)/(z + 1) in N(s), times (z + 1)²: numerator and denominator are
// c0 z² + c1 z + c2 with c0 = K² + 2ζKωn + ωn², c1 = 2(ωn² − K²), c2 = K² − 2ζKωn + ωn².
Biquad DiscreteNotch(const NotchFilter& notch, double Ts) {
  Biquad out;
  if (!notch.active()) return out;
  const double wn = kTwoPi * notch.frequency, k = wn / std::tan(0.5 * wn * Ts);
  const double zp = notch.width / (2.0 * notch.frequency), zz = notch.depth * zp;
  const double d0 = k * k + 2.0 * zp * k * wn + wn * wn;
  out.b0 = (k * k + 2.0 * zz * k * wn + wn * wn) / d0;
  out.b1 = 2.0 * (wn * wn - k * k) / d0;
  out.b2 = (k * k - 2.0 * zz * k * wn + wn * wn) / d0;
  out.a1 = out.b1;
  out.a2 = (k * k - 2.0 * zp * k * wn + wn * wn) / d0;
  return out;
}

}  // namespace blmd
