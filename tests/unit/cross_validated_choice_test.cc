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

}  // namespace
}  // namespace blmd
