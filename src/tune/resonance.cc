#include "blmd/tune/resonance.h"

#include <algorithm>
#include <cmath>

#include "blmd/constants.h"

namespace blmd {
namespace {

// The margins are searched from four decades below the crossover.
constexpr double kSearchDecades = 1e4;

}  // namespace

void SampledMargins(const SampledRigidLoop& loop, const CascadeGains& gains, bool position,
                    double crossover_hz, LoopMargins* sampled, LoopMargins* continuous) {
  const double low = crossover_hz / kSearchDecades, high = loop.nyquist_hz() * (1.0 - 1e-6);
  if (position) {
    *sampled = ComputeMargins([&](double w) { return loop.PositionLoopAt(gains, w); }, low, high);
    if (continuous) {
      *continuous =
          ComputeMargins([&](double w) { return loop.ContinuousPositionLoopAt(gains, w); }, low,
                         crossover_hz * kSearchDecades);
    }
  } else {
    *sampled = ComputeMargins([&](double w) { return loop.SpeedLoopAt(gains, w); }, low, high);
    if (continuous) {
      *continuous = ComputeMargins([&](double w) { return loop.ContinuousSpeedLoopAt(gains, w); },
                                   low, crossover_hz * kSearchDecades);
    }
  }
}

double WorstCrossingMarginDeg(const SampledRigidLoop& loop, const CascadeGains& gains,
                              double crossover_hz) {
  if (!loop.Poles(gains, false).stable) return -std::numeric_limits<double>::infinity();
  LoopMargins margins;
  SampledMargins(loop, gains, false, crossover_hz, &margins, nullptr);
  return margins.ok ? std::abs(margins.phase_margin_deg) : -std::numeric_limits<double>::infinity();
}

bool MeetsAtEveryCrossing(const SampledRigidLoop& loop, const SampledDesignResult& design,
                          double crossover_hz, double phase_margin_deg) {
  return design.ok &&
         WorstCrossingMarginDeg(loop, design.gains, crossover_hz) >= phase_margin_deg - 0.01;
}

bool MeetsAtEveryCrossing(const SampledRigidLoop& loop, double crossover_hz,
                          double phase_margin_deg) {
  return MeetsAtEveryCrossing(loop, DesignSampledSpeedPi(loop, crossover_hz, phase_margin_deg),
                              crossover_hz, phase_margin_deg);
}

double ResonanceLimitedCrossover(const SampledRigidLoop& loop, double from_hz,
                                 double phase_margin_deg) {
  constexpr int kPerDecade = 50;
  double above = from_hz;
  for (int k = 1; k <= 2 * kPerDecade; ++k) {
    const double f = from_hz * std::pow(10.0, -static_cast<double>(k) / kPerDecade);
    if (!MeetsAtEveryCrossing(loop, f, phase_margin_deg)) {
      above = f;
      continue;
    }
    double below = f;
    while (above - below > 1e-3 * below) {
      const double mid = std::sqrt(above * below);
      (MeetsAtEveryCrossing(loop, mid, phase_margin_deg) ? below : above) = mid;
    }
    const double scale = std::pow(10.0, std::floor(std::log10(below)) - 3.0);
    return std::floor(below / scale) * scale;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

double MotorResonanceHz(const RigidPlant& plant) {
  return plant.two_mass() ? plant.anti_resonance_hz * std::sqrt(1.0 + plant.inertia_ratio)
                          : std::numeric_limits<double>::quiet_NaN();
}

NotchDesign DesignNotch(const RigidPlant& nominal, const std::vector<RigidPlant>& variants,
                        const SampledDrive& drive, double crossover_hz, double phase_margin_deg) {
  NotchDesign out;
  out.resonance_hz = MotorResonanceHz(nominal);
  if (!std::isfinite(out.resonance_hz)) return out;
  // The continuous shafts' gains at the resonance (no notch, the same current loop).
  SampledDrive bare = drive;
  bare.notch = NotchFilter{};
  RigidPlant rigid = nominal;
  rigid.inertia_ratio = 0.0;
  const CascadeGains unit{1.0, 0.0, 0.0};
  const double wr = kTwoPi * out.resonance_hz;
  out.peak_ratio = std::abs(SampledRigidLoop(rigid, bare).ContinuousSpeedLoopAt(unit, wr)) /
                   std::abs(SampledRigidLoop(nominal, bare).ContinuousSpeedLoopAt(unit, wr));
  const double depth = std::clamp(out.peak_ratio, kMinNotchDepth, kMaxNotchDepth);
  double best = -std::numeric_limits<double>::infinity();
  std::vector<SampledDrive> failed;
  for (const double relative : kNotchWidths) {
    SampledDrive filtered = drive;
    filtered.notch = NotchFilter{out.resonance_hz, relative * out.resonance_hz, depth};
    // A notch past the Nyquist frequency cannot run on the drive.
    if (!filtered.Validate().empty()) continue;
    const SampledRigidLoop loop(nominal, filtered);
    const SampledDesignResult design = DesignSampledSpeedPi(loop, crossover_hz, phase_margin_deg);
    if (!MeetsAtEveryCrossing(loop, design, crossover_hz, phase_margin_deg)) {
      failed.push_back(filtered);
      continue;
    }
    double worst = std::numeric_limits<double>::infinity();
    for (const RigidPlant& variant : variants) {
      worst = std::min(worst, WorstCrossingMarginDeg(SampledRigidLoop(variant, filtered),
                                                     design.gains, crossover_hz));
    }
    if (variants.empty()) worst = std::numeric_limits<double>::quiet_NaN();
    // The first width that meets the request, then only a strictly larger worst margin.
    if (!out.ok || worst > best) {
      out.ok = true;
      best = worst;
      out.notch = filtered.notch;
      out.design = design;
      out.worst_variant_margin_deg = worst;
    }
  }
  if (out.ok) return out;
  for (const SampledDrive& filtered : failed) {
    const double highest = ResonanceLimitedCrossover(SampledRigidLoop(nominal, filtered),
                                                     crossover_hz, phase_margin_deg);
    if (std::isfinite(highest) && !(highest <= out.highest_crossover_hz)) {
      out.highest_crossover_hz = highest;
      out.notch = filtered.notch;
    }
  }
  return out;
}

}  // namespace blmd
