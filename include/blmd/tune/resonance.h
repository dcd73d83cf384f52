// The speed loop on a flexible (two-mass) shaft (docs/tuning.md §7.6, §7.7): the margins of
// a sampled loop at every gain crossover, the highest crossover the resonance allows, and the
// notch on the torque command that lets the loop cross over higher.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "blmd/sim/notch_filter.h"
#include "blmd/tune/loop.h"
#include "blmd/tune/sampled_loop.h"

namespace blmd {

// The margins of the tuned sampled loop (the speed loop, or the position loop of the
// cascade) and, when `continuous` is not null, its continuous counterpart, searched from four
// decades below `crossover_hz` to just below the Nyquist frequency.
void SampledMargins(const SampledRigidLoop& loop, const CascadeGains& gains, bool position,
                    double crossover_hz, LoopMargins* sampled, LoopMargins* continuous);

// The speed PI placed at `crossover_hz` on `loop` meets the request on the whole loop: L at
// least `phase_margin_deg` (less 0.01° of rounding) away from −1 at every gain crossover (a
// resonance's peak may cross 1 again) and stable poles (which decide the encirclements).
bool MeetsAtEveryCrossing(const SampledRigidLoop& loop, double crossover_hz,
                          double phase_margin_deg);
// The same for a PI already designed at `crossover_hz` (false when the design failed).
bool MeetsAtEveryCrossing(const SampledRigidLoop& loop, const SampledDesignResult& design,
                          double crossover_hz, double phase_margin_deg);

// The highest crossover below `from_hz` at which MeetsAtEveryCrossing holds: scanned down over
// two decades (50 points per decade), bisected to 1e-3 relative and rounded down to 4
// significant digits (asking for the number as printed succeeds). NaN when none.
double ResonanceLimitedCrossover(const SampledRigidLoop& loop, double from_hz,
                                 double phase_margin_deg);

// The resonance of the motor's speed on a two-mass shaft, Hz: the anti-resonance times
// sqrt(1 + Jl/Jm) (docs/effects.md, two_mass). NaN for a rigid shaft.
double MotorResonanceHz(const RigidPlant& plant);

// The notch chosen for a speed loop at `crossover_hz` (docs/tuning.md §7.7):
//  - centred on the nominal plant's resonance;
//  - its depth the rigid shaft's gain over the two-mass shaft's at the resonance (the notch
//    flattens the peak to the rigid line), kept within [kMinNotchDepth, kMaxNotchDepth];
//  - its width, among kNotchWidths times the resonance, the one that keeps the largest
//    smallest margin on `variants` (the plants at the ends of the resonance's range), the
//    narrower on a tie, among those with which the nominal loop meets the request at every
//    crossing.
struct NotchDesign {
  bool ok = false;  // a width met the request on the nominal plant
  NotchFilter notch;
  SampledDesignResult design;  // the speed PI with the notch in the loop
  double resonance_hz = std::numeric_limits<double>::quiet_NaN();
  double peak_ratio = std::numeric_limits<double>::quiet_NaN();  // rigid / two-mass gain at it
  // The smallest distance of L from −1 (deg, over every crossing) on the variants with the
  // chosen notch; −inf when one of them is unstable, NaN without variants.
  double worst_variant_margin_deg = std::numeric_limits<double>::quiet_NaN();
  // Not ok: the highest crossover any of the widths allows, `notch` the one that allows it
  // (NaN: none within two decades below the request).
  double highest_crossover_hz = std::numeric_limits<double>::quiet_NaN();
};
inline constexpr double kMinNotchDepth = 0.01, kMaxNotchDepth = 0.5;
inline constexpr double kNotchWidths[] = {0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0};

NotchDesign DesignNotch(const RigidPlant& nominal, const std::vector<RigidPlant>& variants,
                        const SampledDrive& drive, double crossover_hz, double phase_margin_deg);

// The smallest distance (deg) from −1 of the speed loop of `gains` over its gain crossovers;
// −inf when the closed loop is unstable or the loop does not cross 1.
double WorstCrossingMarginDeg(const SampledRigidLoop& loop, const CascadeGains& gains,
                              double crossover_hz);

}  // namespace blmd
