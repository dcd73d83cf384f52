// The drive's notch on the torque command (include/blmd/sim/notch_filter.h, docs/tuning.md
// §7.7): the digital filter against the continuous prototype it comes from, the drive's
// controller running it in a closed-loop simulation, the sampled loop the tuning designs on,
// and the notch blmd-tune designs for a two-mass shaft.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <string>
#include <vector>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/notch_filter.h"
#include "blmd/tune/resonance.h"
#include "blmd/tune/sampled_loop.h"

namespace blmd::testing {
namespace {

using Complex = std::complex<double>;

// The bilinear transform maps the digital frequency w to the analogue K tan(w Ts/2), K the
// prewarp constant that puts the notch frequency on itself: the digital response at w is the
// prototype's there, computed here from N(s) as the header writes it.
TEST(NotchFilter, DigitalResponseIsThePrototypesAtTheWarpedFrequency) {
  const NotchFilter notch{180.0, 60.0, 0.05};
  const double ts = 1.0 / 2000.0, wn = kTwoPi * 180.0, k = wn / std::tan(0.5 * wn * ts);
  const double zp = 60.0 / (2.0 * 180.0), zz = 0.05 * zp;
  const Biquad digital = DiscreteNotch(notch, ts);
  double worst = 0.0;
  for (double f = 1.0; f < 1000.0; f *= 1.05) {
    const double w = kTwoPi * f;
    const Complex s(0.0, k * std::tan(0.5 * w * ts));
    const Complex prototype =
        (s * s + 2.0 * zz * wn * s + wn * wn) / (s * s + 2.0 * zp * wn * s + wn * wn);
    worst = std::max(worst, std::abs(digital.At(std::polar(1.0, w * ts)) - prototype));
  }
  EXPECT_LT(worst, 1e-12);
  // Its depth at the centre, 1 at DC and at the Nyquist frequency.
  EXPECT_NEAR(std::abs(digital.At(std::polar(1.0, wn * ts))), 0.05, 1e-12);
  EXPECT_NEAR(std::abs(digital.At(1.0)), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(digital.At(-1.0)), 1.0, 1e-12);
}

// A full notch (depth 0): |N(jw)| = 1/sqrt(2) where |w² − wn²| = 2 ζp wn w, at
// wn (sqrt(1 + ζp²) ± ζp), which lie 2 ζp wn = 2π·width apart.
TEST(NotchFilter, WidthIsTheMinus3DecibelBandOfAFullNotch) {
  const NotchFilter notch{100.0, 30.0, 0.0};
  const double zp = 0.15, wn = kTwoPi * 100.0;
  const double low = wn * (std::sqrt(1.0 + zp * zp) - zp),
               high = wn * (std::sqrt(1.0 + zp * zp) + zp);
  EXPECT_NEAR(std::abs(notch.ContinuousAt(Complex(0.0, low))), 1.0 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(std::abs(notch.ContinuousAt(Complex(0.0, high))), 1.0 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR((high - low) / kTwoPi, 30.0, 1e-9);
  EXPECT_EQ(notch.Validate(1000.0), "");
  EXPECT_NE(NotchFilter({600.0, 30.0, 0.0}).Validate(1000.0).find("Nyquist"), std::string::npos);
  EXPECT_NE(NotchFilter({100.0, 30.0, 1.0}).Validate(1000.0).find("depth"), std::string::npos);
}

// The drive's speed PI with a notch (delay 0, limits far away) in rigid_load's closed-loop
// simulation: the recorded command is the PI of the recorded error, I_k = I_{k-1} + ki Ts e_k,
// v_k = kp e_k + I_k, passed through the notch's difference equation
// y_k = b0 v_k + b1 v_{k-1} + b2 v_{k-2} − a1 y_{k-1} − a2 y_{k-2} written here.
TEST(NotchFilter, ClosedLoopCommandIsThePiThroughTheNotch) {
  const std::string text = R"({
  "name": "notched", "model": "rigid_load",
  "parameters": { "J": 2e-3, "B": 0.04, "Kt": 0.5 },
  "effects": { "two_mass": { "inertia_ratio": 1.5, "anti_resonance_hz": 40,
                             "shaft_damping_ratio": 0.02, "load_damping_share": 0.0 } },
  "simulation": { "dt": 1e-4 },
  "experiment": { "input": { "type": "step", "amplitude": 5 }, "duration": 0.3,
                  "sample_rate": 1000,
                  "pid": { "loop": "speed", "Kp": 0.6, "Ki": 20, "u_max": 1e6,
                           "sample_rate": 1000, "delay": 0,
                           "notch": { "frequency": 63, "width": 40, "depth": 0.1 } } } })";
  const Config config = ParseConfig(text, "notched.json");
  ASSERT_TRUE(config.experiment.pid.notch.active());
  Trace trace;
  ASSERT_TRUE(RunExperiment(config, &trace).ok());
  const Biquad c = DiscreteNotch(NotchFilter{63.0, 40.0, 0.1}, 1e-3);
  const auto& u = trace.Column("u");
  const auto& w = trace.Column("w");
  const auto& r = trace.Column("r");
  double integral = 0.0, v1 = 0.0, v2 = 0.0, y1 = 0.0, y2 = 0.0, worst = 0.0, largest = 0.0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    const double e = r[k] - w[k];
    integral += 20.0 * 1e-3 * e;
    const double v = 0.6 * e + integral;
    const double y = c.b0 * v + c.b1 * v1 + c.b2 * v2 - c.a1 * y1 - c.a2 * y2;
    worst = std::max(worst, std::abs(u[k] - y));
    largest = std::max(largest, std::abs(y));
    v2 = v1;
    v1 = v;
    y2 = y1;
    y1 = y;
  }
  EXPECT_GT(largest, 1.0);
  EXPECT_LT(worst, 1e-9 * largest);
}

// A notch at 600 Hz on a 1 kHz controller cannot run: the config says where, in one line.
TEST(NotchFilter, ConfigRefusesANotchAboveTheNyquistFrequency) {
  const std::string text = R"({
  "name": "bad", "model": "rigid_load", "parameters": { "J": 2e-3, "B": 0.04, "Kt": 0.5 },
  "simulation": { "dt": 1e-4 },
  "experiment": { "input": { "type": "step", "amplitude": 5 },
                  "pid": { "loop": "speed", "Kp": 0.6, "u_max": 5, "sample_rate": 1000,
                           "notch": { "frequency": 600, "width": 40, "depth": 0.1 } } } })";
  try {
    ParseConfig(text, "bad.json");
    FAIL() << "accepted";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("bad.json:6:"), std::string::npos) << message;
    EXPECT_NE(message.find("Nyquist"), std::string::npos) << message;
  }
}

// The two-mass shaft of docs/tuning.md §7.6: J 2e-3 kg·m², B 0.04, Kt 0.5, r 1.5, fa 40 Hz,
// zeta 0.02 (resonance 63.2 Hz).
RigidPlant TwoMassShaft() { return {2e-3, 0.04, 0.5, 1.5, 40.0, 0.02, 0.0}; }

// The sampled plant the PI is designed on carries the notch: G(z) with it (the filter's two
// states in series before the shaft) is N(z) times G(z) without it.
TEST(NotchFilter, SampledPlantIsTheNotchTimesTheShaft) {
  const RigidPlant plant = TwoMassShaft();
  SampledDrive bare{1000.0, 1, 0.0, {}};
  SampledDrive notched = bare;
  notched.notch = NotchFilter{63.25, 30.0, 0.1};
  const SampledRigidLoop without(plant, bare), with(plant, notched);
  const Biquad n = DiscreteNotch(notched.notch, 1e-3);
  double worst = 0.0;
  for (double f = 1.0; f < 499.0; f *= 1.1) {
    const double w = kTwoPi * f;
    const Complex expected = n.At(std::polar(1.0, w * 1e-3)) * without.SpeedPlantAt(w);
    worst = std::max(worst, std::abs(with.SpeedPlantAt(w) - expected) / std::abs(expected));
  }
  EXPECT_LT(worst, 1e-9);
}

// On the shaft of docs/tuning.md §7.6 (resonance 63.2 Hz, 1 kHz) a speed loop at 20 Hz with 60°
// is beyond what the resonance allows (15.7 Hz); the notch designed at the resonance meets it:
// on the nominal shaft every crossing at least 60° from −180° (0.01° of rounding), and the
// width chosen keeps the most margin on the shafts 10 % either side.
TEST(NotchFilter, DesignedNotchLetsTheLoopCrossAboveTheResonanceLimit) {
  const RigidPlant plant = TwoMassShaft();
  const SampledDrive drive{1000.0, 1, 0.0, {}};
  EXPECT_FALSE(MeetsAtEveryCrossing(SampledRigidLoop(plant, drive), 20.0, 60.0));
  RigidPlant low = plant, high = plant;
  low.anti_resonance_hz *= 0.9;
  high.anti_resonance_hz *= 1.1;
  const NotchDesign design = DesignNotch(plant, {low, high}, drive, 20.0, 60.0);
  ASSERT_TRUE(design.ok);
  EXPECT_NEAR(design.notch.frequency, 40.0 * std::sqrt(2.5), 1e-9);
  EXPECT_GT(design.notch.depth, kMinNotchDepth - 1e-15);
  EXPECT_LT(design.notch.depth, kMaxNotchDepth + 1e-15);
  SampledDrive notched = drive;
  notched.notch = design.notch;
  const SampledRigidLoop loop(plant, notched);
  EXPECT_GE(WorstCrossingMarginDeg(loop, design.design.gains, 20.0), 60.0 - 0.01);
  // No other width keeps more margin on the two shifted shafts.
  for (const double relative : kNotchWidths) {
    SampledDrive other = drive;
    other.notch =
        NotchFilter{design.notch.frequency, relative * design.notch.frequency, design.notch.depth};
    const SampledRigidLoop candidate(plant, other);
    const SampledDesignResult pi = DesignSampledSpeedPi(candidate, 20.0, 60.0);
    if (!pi.ok || WorstCrossingMarginDeg(candidate, pi.gains, 20.0) < 60.0 - 0.01) continue;
    const double worst =
        std::min(WorstCrossingMarginDeg(SampledRigidLoop(low, other), pi.gains, 20.0),
                 WorstCrossingMarginDeg(SampledRigidLoop(high, other), pi.gains, 20.0));
    EXPECT_LE(worst, design.worst_variant_margin_deg + 1e-9) << relative;
  }
}

}  // namespace
}  // namespace blmd::testing
