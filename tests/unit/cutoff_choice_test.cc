// The equation error's cut-off ladder (include/blmd/ident/fit/cutoff_choice.h,
// docs/identification.md §8a): the plateau, the default on it, a user's cut-off judged.
#include "blmd/ident/fit/cutoff_choice.h"

#include <gtest/gtest.h>

#include <vector>

namespace blmd {
namespace {

ParameterEstimate Estimate(const char* name, double value, double relative_half_width) {
  ParameterEstimate e;
  e.name = name;
  e.value = value;
  e.has_white_interval = true;
  e.ci95_white_low = value * (1.0 - relative_half_width);
  e.ci95_white_high = value * (1.0 + relative_half_width);
  return e;
}

// A ladder with J per rung (B fixed, determined), highest cut-off first.
CutoffChoice Ladder(const std::vector<double>& hz, const std::vector<double>& j,
                    double user_hz = 0.0) {
  CutoffChoice choice;
  choice.ran = true;
  choice.sample_hz = 1000.0;
  choice.user_set = user_hz > 0.0;
  choice.chosen_hz = user_hz;
  for (std::size_t k = 0; k < hz.size(); ++k) {
    CutoffLevel level;
    level.hz = hz[k];
    level.ok = true;
    level.estimates = {Estimate("B", 1e-3, 0.05), Estimate("J", j[k], 0.05)};
    choice.levels.push_back(level);
  }
  return choice;
}

const std::vector<double> kHz = {100, 50, 25, 12.5, 6.25, 3.125};

TEST(CutoffChoice, TheLadderIsOctavesFromATenthOfTheRate) {
  EXPECT_EQ(CutoffLadder(1000.0, 0.0), kHz);
  // A user's 30 Hz takes the place of the nearest rung, 25 Hz.
  EXPECT_EQ(CutoffLadder(1000.0, 30.0), (std::vector<double>{100, 50, 30, 12.5, 6.25, 3.125}));
}

TEST(CutoffChoice, ACleanRecordKeepsATenthOfTheRate) {
  CutoffChoice choice = Ladder(kHz, {2.000, 2.001, 2.002, 2.002, 2.001, 2.000});
  DecideCutoff(&choice);
  EXPECT_TRUE(choice.plateau);
  EXPECT_FALSE(choice.sensitive);
  EXPECT_DOUBLE_EQ(choice.chosen_hz, 100.0);
  EXPECT_DOUBLE_EQ(choice.stable_low_hz, 3.125);
}

TEST(CutoffChoice, NoiseInTheAccelerationMovesTheDefaultDown) {
  // The Delta servo record's ladder before discovery (J in 1e-4 kg m^2).
  CutoffChoice choice = Ladder(kHz, {1.2603, 1.7786, 1.8487, 1.8435, 1.8208, 1.7892});
  DecideCutoff(&choice);
  EXPECT_TRUE(choice.plateau);
  EXPECT_DOUBLE_EQ(choice.chosen_hz, 25.0);
  EXPECT_DOUBLE_EQ(choice.stable_high_hz, 25.0);
  EXPECT_DOUBLE_EQ(choice.stable_low_hz, 3.125);
  EXPECT_FALSE(choice.sensitive);
  EXPECT_FALSE(choice.levels[0].agrees_below);
  EXPECT_FALSE(choice.levels[1].agrees_below);  // 3.9 % per octave
  EXPECT_TRUE(choice.levels[2].agrees_below);
}

TEST(CutoffChoice, AUserCutOffOffThePlateauIsSensitive) {
  CutoffChoice choice = Ladder(kHz, {1.2603, 1.7786, 1.8487, 1.8435, 1.8208, 1.7892}, 100.0);
  DecideCutoff(&choice);
  EXPECT_DOUBLE_EQ(choice.chosen_hz, 100.0);
  EXPECT_TRUE(choice.sensitive);
  choice = Ladder(kHz, {1.2603, 1.7786, 1.8487, 1.8435, 1.8208, 1.7892}, 12.5);
  DecideCutoff(&choice);
  EXPECT_FALSE(choice.sensitive);
}

TEST(CutoffChoice, WithoutAPlateauTheRateOverTenIsKeptAndSaidSensitive) {
  CutoffChoice choice = Ladder(kHz, {1.0, 1.2, 1.44, 1.73, 2.07, 2.49});
  DecideCutoff(&choice);
  EXPECT_FALSE(choice.plateau);
  EXPECT_TRUE(choice.sensitive);
  EXPECT_DOUBLE_EQ(choice.chosen_hz, 100.0);
}

TEST(CutoffChoice, AnEstimateTheRecordHardlyDeterminesDoesNotBreakThePlateau) {
  // B's white interval is +-80 %: it may wander; J holds.
  CutoffChoice choice = Ladder(kHz, {2.0, 2.0, 2.0, 2.0, 2.0, 2.0});
  for (std::size_t k = 0; k < choice.levels.size(); ++k)
    choice.levels[k].estimates[0] = Estimate("B", 1e-3 * (1.0 + 0.3 * static_cast<double>(k)), 0.8);
  DecideCutoff(&choice);
  EXPECT_DOUBLE_EQ(choice.chosen_hz, 100.0);
  EXPECT_FALSE(choice.sensitive);
}

}  // namespace
}  // namespace blmd
