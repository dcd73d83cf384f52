// The cross-validated choice between two qualifying candidates and its check on the stability
// copies (src/ident/discovery/screening.h, docs/discovery.md §3d): which one is added, and when
// a copy of the data changed far below its noise reverses the choice (then the two are
// reported ambiguous).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "ident/discovery/screening.h"

namespace blmd {
namespace {

constexpr double kMargin = 0.01;  // DiscoveryOptions::held_out_margin's default

CandidateOutcome CrossValidated(double on_data, std::vector<double> on_copies) {
  CandidateOutcome o;
  o.cross_validated = true;
  o.cv_after = on_data;
  o.cv_perturbed = std::move(on_copies);
  return o;
}

TEST(CrossValidatedChoice, TheBestGivesWayToOneAsLargeOnlyByTheMargin) {
  // As many parameters: the other must predict better by more than 1 %.
  EXPECT_TRUE(internal::GivesWay(0.2307, 0.2227, false, kMargin));   // 3.5 % better
  EXPECT_FALSE(internal::GivesWay(0.2240, 0.2227, false, kMargin));  // 0.6 % better
  EXPECT_FALSE(internal::GivesWay(0.2227, 0.2307, false, kMargin));
}

TEST(CrossValidatedChoice, TheBestKeepsItsPlaceOverASimplerOneOnlyByTheMargin) {
  // Fewer parameters: the best stays only when it predicts better by more than 1 %.
  EXPECT_FALSE(internal::GivesWay(0.2200, 0.2307, true, kMargin));  // 4.6 % better: stays
  EXPECT_TRUE(internal::GivesWay(0.2290, 0.2307, true, kMargin));   // 0.7 % better: gives way
  EXPECT_TRUE(internal::GivesWay(0.2400, 0.2307, true, kMargin));
}

TEST(CrossValidatedChoice, ACopyThatReversesTheChoiceIsFound) {
  // Stribeck friction best by BIC, cogging with as many parameters better held out on the
  // data (0.2307 against 0.2227) and on the second copy, worse on the first (0.2173 against
  // 0.2227): the first copy reverses the choice.
  const CandidateOutcome stribeck = CrossValidated(0.2307, {0.2173, 0.2337});
  const CandidateOutcome cogging = CrossValidated(0.2227, {0.2227, 0.2227});
  EXPECT_EQ(internal::FirstCopyReversingChoice(stribeck, cogging, false, kMargin),
            std::optional<std::size_t>(0));
  // The second copy alone reverses it: found there.
  const CandidateOutcome later = CrossValidated(0.2307, {0.2337, 0.2173});
  EXPECT_EQ(internal::FirstCopyReversingChoice(later, cogging, false, kMargin),
            std::optional<std::size_t>(1));
}

TEST(CrossValidatedChoice, ACopyThatKeepsTheChoiceOrCannotTellIsNoReversal) {
  const CandidateOutcome cogging = CrossValidated(0.2227, {0.2227, 0.2227});
  // Every copy prefers cogging by more than the margin, as the data do.
  EXPECT_EQ(internal::FirstCopyReversingChoice(CrossValidated(0.2307, {0.2262, 0.2258}), cogging,
                                               false, kMargin),
            std::nullopt);
  // A copy whose cross-validation failed (NaN) decides nothing.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(internal::FirstCopyReversingChoice(CrossValidated(0.2307, {nan, 0.2337}), cogging,
                                               false, kMargin),
            std::nullopt);
  // Without cross-validation on both there are no copies to compare.
  CandidateOutcome held_out_only = CrossValidated(0.2307, {0.2173, 0.2173});
  held_out_only.cross_validated = false;
  EXPECT_EQ(internal::FirstCopyReversingChoice(held_out_only, cogging, false, kMargin),
            std::nullopt);
  // Fewer copies on one side: only the common ones are compared.
  EXPECT_EQ(internal::FirstCopyReversingChoice(CrossValidated(0.2307, {0.2337, 0.2173}),
                                               CrossValidated(0.2227, {0.2227}), false, kMargin),
            std::nullopt);
}

TEST(DecisionOnCopies, ThePredictionIntervalIsStudentsForOneFurtherSample) {
  // Samples 1, 2, 3: mean 2, s = 1, t(0.975, 2) = 4.302653, so 2 ± 4.302653·sqrt(4/3).
  const internal::SideCheck check = internal::CheckSide({1.0, 2.0, 3.0}, 10.0);
  EXPECT_NEAR(check.low, 2.0 - 4.968275, 1e-5);
  EXPECT_NEAR(check.high, 2.0 + 4.968275, 1e-5);
  EXPECT_TRUE(check.holds);  // 10 lies beyond it
  EXPECT_FALSE(internal::CheckSide({1.0, 2.0, 3.0}, 6.0).holds);
}

TEST(DecisionOnCopies, CopiesThatAgreeToTheirLastDigitsHold) {
  // A model that depends smoothly on its data: the copies move the ratio by ~1e-9.
  const internal::SideCheck check =
      internal::CheckSide({0.9812, 0.9812 * (1 + 2e-9), 0.9812 * (1 - 1e-9)}, 0.99);
  EXPECT_TRUE(check.holds);
  EXPECT_GT(check.low, 0.9811);
  EXPECT_LT(check.high, 0.9813);
}

TEST(DecisionOnCopies, ACopyAcrossTheThresholdOrAWideScatterDoesNotHold) {
  // One copy on the other side.
  EXPECT_FALSE(internal::CheckSide({0.975, 0.995, 0.976}, 0.99).holds);
  // All on the data's side, 1.5 % from the threshold, but scattered by as much: a further
  // copy could cross it.
  const internal::SideCheck wide = internal::CheckSide({0.9759, 0.9845, 0.9863}, 0.99);
  EXPECT_FALSE(wide.holds);
  EXPECT_LT(wide.low, 0.99);
  EXPECT_GT(wide.high, 0.99);
  // The same distance with a scatter ten times smaller holds.
  EXPECT_TRUE(internal::CheckSide({0.9759, 0.9768, 0.9770}, 0.99).holds);
}

TEST(DecisionOnCopies, FailedCopiesDecideNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const internal::SideCheck alone = internal::CheckSide({0.97, nan, nan}, 0.99);
  EXPECT_TRUE(alone.holds);
  EXPECT_EQ(alone.low, 0.97);
  EXPECT_EQ(alone.high, 0.97);
  EXPECT_TRUE(internal::CheckSide({nan, 0.995}, 0.99).holds);  // nothing on the data
}

TEST(DecisionOnCopies, AFailedCopyLeavesAWiderInterval) {
  // A failed copy is left out, and two samples give t(0.975, 1) = 12.71 rather than three's
  // 4.30: the same two values that hold beside a third agreeing one may no longer hold.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(internal::CheckSide({0.975, 0.977, 0.976}, 0.99).holds);  // up to 0.98097
  const internal::SideCheck two = internal::CheckSide({0.975, 0.977, nan}, 0.99);
  EXPECT_FALSE(two.holds);
  // 0.976 ± 12.7062·0.0014142·sqrt(3/2)
  EXPECT_NEAR(two.high, 0.976 + 12.7062 * std::sqrt(2e-6) * std::sqrt(1.5), 1e-5);
}

TEST(DecisionOnCopies, TheChoiceIsCheckedAsTheRatioGivesWayCompares) {
  // As many parameters: the other's NRMSE over the best's; fewer: the best's over the other's.
  const CandidateOutcome stribeck = CrossValidated(0.2282, {0.2262, 0.2258});
  const CandidateOutcome cogging = CrossValidated(0.2227, {0.2227, 0.2226});
  const std::vector<double> same_size = internal::ChoiceRatios(stribeck, cogging, false);
  ASSERT_EQ(same_size.size(), 3u);
  EXPECT_DOUBLE_EQ(same_size[0], 0.2227 / 0.2282);
  EXPECT_DOUBLE_EQ(same_size[2], 0.2226 / 0.2258);
  const std::vector<double> fewer = internal::ChoiceRatios(stribeck, cogging, true);
  EXPECT_DOUBLE_EQ(fewer[1], 0.2262 / 0.2227);
  // No copy reverses this choice, but they scatter too widely for it to hold.
  EXPECT_EQ(internal::FirstCopyReversingChoice(stribeck, cogging, false, kMargin), std::nullopt);
  EXPECT_FALSE(internal::CheckRatio(same_size, 1.0 - kMargin).holds);
}

TEST(DecisionOnCopies, ARatioIsJudgedOnALogScale) {
  // Ratios 1, e, e^2: logs 0, 1, 2, so the interval is exp(1 ± 4.968275), positive.
  const internal::SideCheck check = internal::CheckRatio({1.0, std::exp(1.0), std::exp(2.0)}, 0.01);
  EXPECT_NEAR(check.low, std::exp(1.0 - 4.968275), 1e-6);
  EXPECT_NEAR(check.high, std::exp(1.0 + 4.968275), 1e-2);
  EXPECT_TRUE(check.holds);  // 0.01 = exp(-4.6) lies below exp(-3.97)
  EXPECT_FALSE(internal::CheckRatio({1.0, std::exp(1.0), std::exp(2.0)}, 0.05).holds);
  // A ratio that is not positive cannot be judged: it decides nothing.
  EXPECT_TRUE(internal::CheckRatio({0.5, -1.0, 0.0}, 0.99).holds);
}

TEST(DecisionOnCopies, AScorePastTheThresholdOnTheDataAndTheCopyDecidesAlike) {
  constexpr double kBicMargin = 10.0;
  // A shaft dithering between encoder counts at standstill: Coulomb friction's plain ΔBIC
  // moves from -8415 to -4328 on a copy changed by 1e-9; both far past -10, same decision.
  EXPECT_FALSE(internal::ScoreMoveReverses(-8415.0, -4328.0, kBicMargin, 841.5));
  EXPECT_FALSE(internal::ScoreMoveReverses(-8415.0, -4639.0, kBicMargin, 841.5));
  // A detent that captures the shaft on one copy and not the other: -3462 against +417.
  EXPECT_TRUE(internal::ScoreMoveReverses(-3462.0, 417.0, kBicMargin, 346.2));
  EXPECT_TRUE(internal::ScoreMoveReverses(417.0, -3462.0, kBicMargin, 41.7));
  // Across the threshold by less than the score's usual move: the same decision.
  EXPECT_FALSE(internal::ScoreMoveReverses(-10.4, -9.8, kBicMargin, 1.0));
  // Neither side passes: nothing is added either way.
  EXPECT_FALSE(internal::ScoreMoveReverses(-5.0, 300.0, kBicMargin, 1.0));
}

}  // namespace
}  // namespace blmd
