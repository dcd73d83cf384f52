// The prbs and chirp inputs (docs/config.md, experiment.input), against their definitions:
// the maximum-length sequence's period, balance and two-valued autocorrelation; the cursor's
// values and next-change times at the bit edges; the chirp against its closed form and its
// instantaneous frequency against the zero crossings; the config reader's defaults.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/dc_servo/dc_servo.h"
#include "blmd/sim/experiment.h"
#include "sim/input_read.h"
#include "support/fast_reference.h"
#include "support/test_support.h"

namespace blmd {
namespace {

InputSignal Prbs(int order, std::uint32_t seed = 1, double clock = 0.01, double t0 = 0.0) {
  InputSignal signal;
  signal.kind = InputSignal::Kind::kPrbs;
  signal.amplitude = 12.0;
  signal.offset = 1.0;
  signal.t0 = t0;
  signal.clock = clock;
  signal.order = order;
  signal.seed = seed;
  return signal;
}

// Bit k of the sequence as +-1, read by the signal at the middle of the bit.
std::vector<int> PlusMinusBits(const InputSignal& signal, std::size_t count) {
  std::vector<int> bits(count);
  for (std::size_t k = 0; k < count; ++k) {
    const double u = signal.At(signal.t0 + (static_cast<double>(k) + 0.5) * signal.clock);
    EXPECT_TRUE(u == signal.offset + signal.amplitude || u == signal.offset - signal.amplitude);
    bits[k] = u > signal.offset ? 1 : -1;
  }
  return bits;
}

// The smallest p > 0 with bits[k + p] == bits[k] for every k (bits covers two periods or more).
std::size_t SmallestPeriod(const std::vector<int>& bits) {
  for (std::size_t p = 1; p < bits.size(); ++p) {
    bool periodic = true;
    for (std::size_t k = 0; k + p < bits.size() && periodic; ++k) periodic = bits[k] == bits[k + p];
    if (periodic) return p;
  }
  return bits.size();
}

TEST(Prbs, PeriodBalanceAndAutocorrelationAreThoseOfAnMSequence) {
  for (int n = 3; n <= 12; ++n) {
    SCOPED_TRACE("order " + std::to_string(n));
    const long period = (1L << n) - 1;
    const auto bits = PlusMinusBits(Prbs(n), static_cast<std::size_t>(3 * period));
    EXPECT_EQ(SmallestPeriod(bits), static_cast<std::size_t>(period));
    long high = 0;
    for (long k = 0; k < period; ++k) high += bits[static_cast<std::size_t>(k)] > 0;
    EXPECT_EQ(high, 1L << (n - 1));
    EXPECT_EQ(period - high, (1L << (n - 1)) - 1);
    // Circular autocorrelation over one period, in whole numbers: N at lag 0, -1 elsewhere
    // (R(tau)/N = 1 and -1/N exactly).
    for (long lag = 0; lag < period; ++lag) {
      long sum = 0;
      for (long k = 0; k < period; ++k) {
        sum += bits[static_cast<std::size_t>(k)] * bits[static_cast<std::size_t>(k + lag)];
      }
      ASSERT_EQ(sum, lag == 0 ? period : -1) << "lag " << lag;
    }
  }
}

// Every tap set of the table is primitive: x has order exactly 2^n - 1 modulo p(x), so the
// register runs through every nonzero state (checked through the signal: the sequence's
// period, for every order the test can afford to run through; 2..22 here).
TEST(Prbs, EveryOrderOfTheTableHasTheFullPeriod) {
  for (int n = 2; n <= 31; ++n) EXPECT_NE(PrbsPolynomial(n), 0u) << n;
  EXPECT_EQ(PrbsPolynomial(1), 0u);
  EXPECT_EQ(PrbsPolynomial(32), 0u);
  for (int n = 2; n <= 22; ++n) {
    SCOPED_TRACE("order " + std::to_string(n));
    const InputSignal signal = Prbs(n, 1, 1.0);
    const std::uint64_t period = (std::uint64_t{1} << n) - 1;
    // The window of n bits at k is the register's state in another basis: all distinct over
    // a period and the whole sequence repeating after it, the period is maximal. Reading
    // through a cursor keeps this O(period).
    InputCursor cursor(signal);
    std::vector<char> seen(std::size_t{1} << n, 0);
    std::uint32_t window = 0;
    std::vector<char> first(static_cast<std::size_t>(n));
    for (std::uint64_t k = 0; k < period + static_cast<std::uint64_t>(n) - 1; ++k) {
      const int bit = cursor.At(static_cast<double>(k) + 0.5) > signal.offset ? 1 : 0;
      window =
          ((window << 1) | static_cast<std::uint32_t>(bit)) & static_cast<std::uint32_t>(period);
      if (k + 1 >= static_cast<std::uint64_t>(n)) {
        ASSERT_EQ(seen[window], 0) << "window repeated at bit " << k;
        seen[window] = 1;
      }
    }
    EXPECT_EQ(seen[0], 0);  // the all-zero window never occurs
    // And the sequence repeats: the bits of period P on equal those from 0.
    for (std::uint64_t k = 0; k < 64; ++k) {
      EXPECT_EQ(signal.PrbsBit(static_cast<double>(k) + 0.5),
                signal.PrbsBit(static_cast<double>(k + period) + 0.5));
    }
  }
}

TEST(Prbs, SeedIsTheStartStateAndShiftsTheSequence) {
  // Different seeds give shifts of one sequence: the seed's sequence appears in seed 1's.
  const int n = 7;
  const long period = (1L << n) - 1;
  const auto reference = PlusMinusBits(Prbs(n, 1), static_cast<std::size_t>(2 * period));
  for (std::uint32_t seed : {2u, 5u, 64u, 127u}) {
    const auto bits = PlusMinusBits(Prbs(n, seed), static_cast<std::size_t>(period));
    int matches = 0;
    for (long shift = 0; shift < period; ++shift) {
      bool same = true;
      for (long k = 0; k < period && same; ++k) {
        same = bits[static_cast<std::size_t>(k)] == reference[static_cast<std::size_t>(k + shift)];
      }
      matches += same;
    }
    EXPECT_EQ(matches, 1) << "seed " << seed;
  }
  // Bit 0 is the seed's top bit: seed 1 starts with n - 1 low bits, then a high one.
  const auto bits = PlusMinusBits(Prbs(n, 1), static_cast<std::size_t>(n));
  for (int k = 0; k + 1 < n; ++k) EXPECT_EQ(bits[static_cast<std::size_t>(k)], -1) << k;
  EXPECT_EQ(bits[static_cast<std::size_t>(n - 1)], 1);
  EXPECT_EQ(Prbs(n, 1u << (n - 1)).At(0.0), 13.0);
}

// The cursor (what the simulators read) at every edge, just before it and at the step grid,
// against the stateless At; NextChange is the next edge where the bit changes.
TEST(Prbs, CursorValuesAndNextChangeAtTheBitEdges) {
  const double clock = 0.002, t0 = 0.1;
  const InputSignal signal = Prbs(9, 37, clock, t0);
  const std::size_t count = 3 * 511;
  const auto bits = PlusMinusBits(signal, count + 20);
  InputCursor cursor(signal);
  EXPECT_EQ(cursor.At(0.05), signal.offset);
  EXPECT_EQ(cursor.NextChange(0.05), t0);
  for (std::size_t k = 0; k < count; ++k) {
    // The edge as a trace's sample time computes it, and the middle of the bit.
    const double edge = t0 + static_cast<double>(k) * clock;
    const double expected = bits[k] > 0 ? 13.0 : -11.0;
    ASSERT_EQ(cursor.At(edge), expected) << "bit " << k;
    ASSERT_EQ(signal.At(edge), expected) << "bit " << k;
    std::size_t change = k + 1;
    while (bits[change] == bits[k]) ++change;
    const double next_edge = t0 + static_cast<double>(change) * clock;
    const double mid = edge + 0.5 * clock;
    ASSERT_EQ(cursor.At(mid), expected);
    const double next = cursor.NextChange(mid);
    // Just before the edge (inside the reading window of 1e-6 of the edge's clock count),
    // so that a fast path reads again from there; never after it.
    ASSERT_LE(next, next_edge) << "bit " << k;
    ASSERT_GT(next, next_edge - 1e-6 * clock * static_cast<double>(change) - 1e-15) << "bit " << k;
    ASSERT_GT(next, mid) << "bit " << k;
    // Nothing changes before it.
    ASSERT_EQ(cursor.At(0.5 * (mid + next)), expected);
  }
}

// The simulators' own way of reading: just after step midpoints (sim/input_read.h) from
// t = k dt, re-reading only once NextChange is reached. The values read must be those of the
// stateless At at every step (so the fast path and the reference see the same input).
TEST(Prbs, ReadingOnlyAtNextChangeSeesEveryChange) {
  const double dt = 1e-5;
  const InputSignal signal = Prbs(10, 1, 0.001, 0.0);
  InputCursor cursor(signal);
  double value = 0.0, next_change = -1e300;
  long reads = 0, changes = 0;
  double previous = std::numeric_limits<double>::quiet_NaN();
  for (long step = 0; step < 200000; ++step) {
    const double t_mid = internal::InputReadTime(static_cast<double>(step) * dt, dt);
    if (t_mid >= next_change) {
      value = cursor.At(t_mid);
      next_change = cursor.NextChange(t_mid);
      ++reads;
    }
    ASSERT_EQ(value, signal.At(t_mid)) << "step " << step;
    changes += !(value == previous) && step > 0;
    previous = value;
  }
  // One read per change (plus the first): the runs of equal bits are skipped.
  EXPECT_EQ(reads, changes + 1);
}

InputSignal Chirp(InputSignal::ChirpShape shape, double f0, double f1, double sweep) {
  InputSignal signal;
  signal.kind = InputSignal::Kind::kChirp;
  signal.amplitude = 2.5;
  signal.offset = 0.5;
  signal.t0 = 0.25;
  signal.f0 = f0;
  signal.f1 = f1;
  signal.sweep = sweep;
  signal.shape = shape;
  return signal;
}

// The closed form in long double (an independent evaluation), reduced to one turn.
long double ClosedForm(const InputSignal& s, long double t) {
  const long double tau = t - s.t0;
  if (tau < 0) return s.offset;
  const long double T = s.sweep, f0 = s.f0, f1 = s.f1;
  const long double u = std::min(tau, T);
  long double turns = s.shape == InputSignal::ChirpShape::kLinear
                          ? f0 * u + (f1 - f0) * u * u / (2 * T)
                          : f0 * T / std::log(f1 / f0) * (std::pow(f1 / f0, u / T) - 1);
  if (tau > T) turns += f1 * (tau - T);
  turns -= std::floor(turns);
  return s.offset + s.amplitude * std::sin(2 * std::numbers::pi_v<long double> * turns);
}

// A time so far from t0 that its bit index exceeds 2^64 (1e300 s at a 1 ms clock): the index
// saturates instead of an undefined float-to-integer conversion (-fsanitize=float-cast-
// overflow stopped here), and the value is still one of the two levels.
TEST(Prbs, AFarTimeGivesALevelNotUndefinedBehaviour) {
  const InputSignal signal = Prbs(7, 1, 1e-3);
  for (double t : {1e300, 1e30, 1.8446744073709552e16}) {
    const double u = signal.At(t);
    EXPECT_TRUE(u == 13.0 || u == -11.0) << t << ": " << u;
  }
}

TEST(Chirp, ValueMatchesTheClosedFormAtRandomTimes) {
  std::mt19937_64 generator(20240522);
  for (const auto shape : {InputSignal::ChirpShape::kLinear, InputSignal::ChirpShape::kLog}) {
    const InputSignal signal = Chirp(shape, 0.5, 40.0, 8.0);
    std::uniform_real_distribution<double> time(0.0, 10.0);  // before t0, in and after the sweep
    InputCursor cursor(signal);
    for (int k = 0; k < 1000; ++k) {
      const double t = time(generator);
      const double expected = static_cast<double>(ClosedForm(signal, t));
      ASSERT_NEAR(signal.At(t), expected, 1e-12) << "t = " << t;
      ASSERT_EQ(cursor.At(t), signal.At(t));
      ASSERT_EQ(cursor.NextChange(t), t);  // continuous: read at every step
    }
    EXPECT_EQ(signal.At(0.1), 0.5);   // offset before t0
    EXPECT_EQ(signal.At(0.25), 0.5);  // phase 0 at t0
  }
}

// Zero crossings of sin(phi) are half a turn apart: between two, f ~ 1/(2 gap) at the midpoint.
TEST(Chirp, FrequencyFromZeroCrossingsFollowsTheSweep) {
  for (const auto shape : {InputSignal::ChirpShape::kLinear, InputSignal::ChirpShape::kLog}) {
    const InputSignal signal = Chirp(shape, 1.0, 50.0, 6.0);
    const double dt = 1e-6;
    std::vector<double> crossings;
    double previous = signal.At(signal.t0 + 0.5 * dt) - signal.offset;
    for (double t = signal.t0 + 1.5 * dt; t < signal.t0 + 8.0; t += dt) {
      const double now = signal.At(t) - signal.offset;
      if ((previous < 0.0) != (now < 0.0)) {
        crossings.push_back(t - dt * now / (now - previous));  // linear interpolation
      }
      previous = now;
    }
    // Turns over [0, 8 s]: the sweep's integral plus 2 s at f1.
    const double turns = signal.ChirpPhase(signal.t0 + 8.0) / (2.0 * std::numbers::pi);
    EXPECT_NEAR(static_cast<double>(crossings.size()), 2.0 * turns, 2.0);
    double worst = 0.0;
    for (std::size_t k = 1; k < crossings.size(); ++k) {
      const double mid = 0.5 * (crossings[k] + crossings[k - 1]);
      const double estimate = 0.5 / (crossings[k] - crossings[k - 1]);
      worst = std::max(worst, std::abs(estimate / signal.ChirpFrequency(mid) - 1.0));
    }
    EXPECT_LT(worst, 0.01);
    EXPECT_EQ(signal.ChirpFrequency(signal.t0 + 7.0), 50.0);  // held after the sweep
  }
}

Config LoadText(const std::string& input, const std::string& experiment_extra = "") {
  return ParseConfig(R"({"model": "dc_servo",
    "parameters": {"R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5},
    "experiment": {"input": )" +
                         input + experiment_extra + "}}",
                     "config.json");
}

TEST(InputConfig, PrbsAndChirpKeysAndDefaults) {
  const Config prbs = LoadText(R"({"type": "prbs", "amplitude": 12, "clock": 0.01, "order": 7})",
                               R"(, "duration": 2)");
  const InputSignal& p = prbs.experiment.input;
  EXPECT_EQ(p.kind, InputSignal::Kind::kPrbs);
  EXPECT_EQ(p.order, 7);
  EXPECT_EQ(p.seed, 1u);
  EXPECT_EQ(p.clock, 0.01);
  EXPECT_EQ(p.offset, 0.0);
  const Config chirp = LoadText(
      R"({"type": "chirp", "amplitude": 12, "f0": 0.5, "f1": 20, "shape": "log", "t0": 0.1})",
      R"(, "duration": 3)");
  const InputSignal& c = chirp.experiment.input;
  EXPECT_EQ(c.kind, InputSignal::Kind::kChirp);
  EXPECT_EQ(c.shape, InputSignal::ChirpShape::kLog);
  EXPECT_EQ(c.sweep, 3.0);  // the experiment's duration
  EXPECT_EQ(c.t0, 0.1);
  const Config swept =
      LoadText(R"({"type": "chirp", "f0": 0, "f1": 20, "duration": 1.5})", R"(, "duration": 3)");
  EXPECT_EQ(swept.experiment.input.sweep, 1.5);
  EXPECT_EQ(swept.experiment.input.shape, InputSignal::ChirpShape::kLinear);
}

// The fast paths (which read a prbs only at its bit changes and a chirp at every step) give
// the reference paths' trace, within 1e-9 relative (as tests/unit/fast_path_test.cc).
template <typename ModelT>
double FastAgainstReference(const Config& config) {
  const testing::FastAndReference runs = testing::RunFastAndReference<ModelT>(config);
  EXPECT_TRUE(runs.fast_status.ok());
  EXPECT_TRUE(runs.reference_status.ok());
  std::string where;
  return testing::WorstRelativeDeviation(runs.fast, runs.reference, &where);
}

TEST(InputFastPath, PrbsAndChirpMatchTheReferencePaths) {
  for (const char* name : {"ganesh-prbs.json", "ganesh-chirp.json"}) {
    const Config config = LoadConfig(testing::SourcePath(std::string("configs/") + name));
    EXPECT_LT(FastAgainstReference<DcServoModel>(config), 1e-9) << name;
  }
  Config blmd = LoadConfig(testing::SourcePath("configs/blmd-d31x.json"));
  blmd.experiment.duration = 0.05;
  InputSignal& input = blmd.experiment.input;
  input = InputSignal();
  input.kind = InputSignal::Kind::kPrbs;
  input.amplitude = 0.5;
  input.clock = 0.002;
  input.order = 5;
  EXPECT_LT(FastAgainstReference<BlmdDriveModel>(blmd), 1e-9) << "blmd prbs";
  input = InputSignal();
  input.kind = InputSignal::Kind::kChirp;
  input.amplitude = 0.5;
  input.f0 = 10.0;
  input.f1 = 200.0;
  input.sweep = 0.05;
  EXPECT_LT(FastAgainstReference<BlmdDriveModel>(blmd), 1e-9) << "blmd chirp";
}

// Recorded samples stamped exactly on a step's midpoint (microsecond stamps with a 50 us
// offset and dt = 100 us put one sample in a hundred there) take effect in the same step
// whatever their last bit, so that a build that rounds t + dt / 2 differently (an FMA build)
// simulates the same record. With dt a power of two the stamps (10 j + 3.5) dt and the
// simulators' midpoints are exact in every build: the test nudges every stamp by one ulp up
// and down and compares the two runs, on each model and each path.
InputSignal MidpointStamps(double dt, double duration, double level, int direction) {
  InputSignal input;
  input.kind = InputSignal::Kind::kRecorded;
  input.times = {0.0};
  input.values = {level};
  for (int j = 1; (10.0 * j + 3.5) * dt < duration; ++j) {
    const double stamp = (10.0 * j + 3.5) * dt;
    input.times.push_back(
        std::nextafter(stamp, direction * std::numeric_limits<double>::infinity()));
    input.values.push_back(level * (j % 2 == 1 ? 0.5 : 1.0));
  }
  return input;
}

// `config` with the stamps nudged up and with them nudged down.
std::pair<Config, Config> NudgedUpAndDown(const Config& config, double level) {
  Config up = config, down = config;
  up.experiment.input = MidpointStamps(config.simulation.dt, config.experiment.duration, level, 1);
  down.experiment.input =
      MidpointStamps(config.simulation.dt, config.experiment.duration, level, -1);
  return {up, down};
}

// The worst relative difference between the runs on stamps nudged up and down: the model's
// Simulate (rigid_load has one path).
double MidpointStampSensitivity(const Config& config, double level) {
  const auto [up, down] = NudgedUpAndDown(config, level);
  Trace a, b;
  EXPECT_TRUE(RunExperiment(up, &a).ok());
  EXPECT_TRUE(RunExperiment(down, &b).ok());
  std::string where;
  return testing::WorstRelativeDeviation(a, b, &where);
}

// The same over the fast path (Simulate) and the reference path.
template <typename ModelT>
double MidpointStampSensitivityBothPaths(const Config& config, double level) {
  const auto [up, down] = NudgedUpAndDown(config, level);
  const testing::FastAndReference a = testing::RunFastAndReference<ModelT>(up);
  const testing::FastAndReference b = testing::RunFastAndReference<ModelT>(down);
  EXPECT_TRUE(a.fast_status.ok() && a.reference_status.ok()) << a.fast_status.message;
  EXPECT_TRUE(b.fast_status.ok() && b.reference_status.ok()) << b.fast_status.message;
  std::string where;
  return std::max(testing::WorstRelativeDeviation(a.fast, b.fast, &where),
                  testing::WorstRelativeDeviation(a.reference, b.reference, &where));
}

TEST(RecordedInput, StampsOnAStepMidpointDoNotDependOnTheirLastBit) {
  const Config shaft = ParseConfig(R"({
  "name": "shaft", "model": "rigid_load",
  "parameters": { "J": 2e-4, "B": 1e-5, "Kt": 0.05 },
  "effects": { "coulomb_friction": { "Tc": 0.002 } },
  "simulation": { "dt": 0.0001220703125 },
  "experiment": { "input": { "type": "step", "amplitude": 1.0 }, "duration": 0.5,
                  "sample_rate": 1000 }
})",
                                   "shaft.json");
  const double rigid = MidpointStampSensitivity(shaft, 1.0);
  Config servo = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  servo.simulation.dt = 0x1p-17;  // 7.6 us
  servo.experiment.duration = 0.2;
  const double dc = MidpointStampSensitivityBothPaths<DcServoModel>(servo, 24.0);
  Config drive = LoadConfig(testing::SourcePath("configs/blmd-d31x.json"));
  drive.simulation.dt = 0x1p-20;                // 0.95 us
  drive.parameters.Set("Tpwm", 0x1p-12);        // 244 us, 256 steps
  drive.parameters.Set("delta", 20 * 0x1p-20);  // 19 us
  drive.experiment.duration = 0.02;
  const double blmd = MidpointStampSensitivityBothPaths<BlmdDriveModel>(drive, 1.0);
  std::printf("[ measured ] one-ulp stamp nudges move rigid_load %.3g, dc_servo %.3g, blmd %.3g\n",
              rigid, dc, blmd);
  EXPECT_LT(rigid, 1e-9);
  EXPECT_LT(dc, 1e-9);
  EXPECT_LT(blmd, 1e-9);
}

}  // namespace
}  // namespace blmd
