// A notch filter on a drive's torque (force) command (docs/tuning.md §7.7): the filter drive
// makers put between the speed controller and the current loop to keep a mechanical
// resonance out of the speed loop.
//
// Continuous prototype (a second-order notch; Ellis, Control System Design Guide, 4th ed.,
// 2012, ch. 9):
//     N(s) = (s² + 2 ζz ωn s + ωn²) / (s² + 2 ζp ωn s + ωn²),
// ωn = 2π·frequency; its gain at ωn is ζz/ζp = depth and far from ωn it is 1; the width is the
// −3 dB bandwidth of its poles, 2 ζp·frequency (Hz), so ζp = width/(2·frequency) and
// ζz = depth·ζp. The drive runs it at its sample time Ts as the bilinear (Tustin) transform
// prewarped at ωn, s = K (z − 1)/(z + 1) with K = ωn / tan(ωn Ts/2) (Franklin, Powell &
// Workman, Digital Control of Dynamic Systems, 3rd ed., 1998, §6.3): the digital filter's
// centre frequency and depth are the continuous one's exactly.
#pragma once

#include <complex>
#include <string>

#include "blmd/sim/biquad.h"

namespace blmd {

struct NotchFilter {
  double frequency = 0.0;  // Hz, the centre ωn/2π; 0: no filter
  double width = 0.0;      // Hz, the −3 dB width of its poles, 2 ζp·frequency, > 0
  double depth = 0.0;      // its gain at the centre: 0 (a full notch) to < 1
  bool active() const { return frequency > 0.0; }
  // "" when the filter can run at sample rate `sample_rate_hz`, else what is wrong (one
  // line): frequency below the Nyquist frequency, width > 0, depth in [0, 1).
  std::string Validate(double sample_rate_hz) const;
  // N(s) of the continuous prototype (1 when not active).
  std::complex<double> ContinuousAt(std::complex<double> s) const;
};

// The prewarped Tustin form of `notch` at sample time Ts (the identity when it is not active).
Biquad DiscreteNotch(const NotchFilter& notch, double Ts);

}  // namespace blmd
