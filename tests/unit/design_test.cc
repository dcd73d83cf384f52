// Experiment design (include/blmd/ident/experiment_design/experiment_design.h, docs/design.md) in
// process: the predicted covariance against an information matrix built here from sensitivities
// simulated independently (central differences in ln J, ln B), its closed forms (one observed
// column: the cost's covariance is the Cramér–Rao bound; the half-width's log-scale form), the
// limits, the families' shapes and the refusals. The calibration against simulated
// experiments is tests/studies/design_study_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/ident/experiment_design/experiment_design.h"
#include "blmd/io/config.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

constexpr double kSigmaI = 0.014, kSigmaW = 2.5;

DesignProblem Ganesh(std::vector<std::string> observe = {"i", "w"}) {
  DesignProblem problem = MakeDesignProblem(LoadConfig(SourcePath("configs/ganesh-square.json")));
  problem.observe = observe;
  problem.sigma.clear();
  for (const auto& column : observe) problem.sigma.push_back(column == "i" ? kSigmaI : kSigmaW);
  return problem;
}

std::vector<double> SampleTimes(double duration, double rate) {
  Experiment e;
  e.duration = duration;
  e.sample_rate = rate;
  return e.SampleTimes();
}

Trace Response(const DesignProblem& problem, const InputSignal& input) {
  Trace response;
  EXPECT_TRUE(SimulateSampledInput(problem, input, SampleTimes(2.0, 2000.0), &response).ok());
  return response;
}

TEST(DesignHalfWidth, LinearAndLogScaleClosedForms) {
  EXPECT_DOUBLE_EQ(Ci95HalfWidth(5.0, 0.1, false), 1.959963984540054 * 0.1);
  // Half the width of [x e^(-1.96 sd), x e^(1.96 sd)]: x sinh(1.96 sd).
  EXPECT_DOUBLE_EQ(Ci95HalfWidth(2e-5, 0.3, true), 2e-5 * std::sinh(1.959963984540054 * 0.3));
  EXPECT_NEAR(Ci95HalfWidth(2e-5, 1e-4, true), 2e-5 * 1.96e-4, 2e-5 * 1e-7);
}

// The information matrix from sensitivities this test simulates itself: y(ln J ± h) for each
// observed column, S = (y+ - y-)/2h, F = sum_c S_c^T S_c / sigma_c^2; and the cost's sandwich
// with a_c = 1/(C N_c (Var_c + sigma_c^2)).
TEST(DesignPrediction, MatchesSensitivitiesSimulatedIndependently) {
  const DesignProblem problem = Ganesh();
  const InputSignal& square = problem.config.experiment.input;
  const PrecisionPrediction p = PredictPrecision(problem, Response(problem, square));
  ASSERT_TRUE(p.ok) << p.reason;
  const double h = 1e-3;
  const char* names[2] = {"J", "B"};
  std::vector<std::vector<double>> s[2];  // [parameter][column][sample]
  for (int k = 0; k < 2; ++k) {
    Trace plus, minus;
    for (double sign : {1.0, -1.0}) {
      DesignProblem moved = problem;
      moved.config.parameters.Set(names[k],
                                  problem.config.parameters.Get(names[k]) * std::exp(sign * h));
      (sign > 0 ? plus : minus) = Response(moved, square);
    }
    for (const auto& column : problem.observe) {
      std::vector<double> d;
      for (std::size_t n = 0; n < plus.rows(); ++n)
        d.push_back((plus.Column(column)[n] - minus.Column(column)[n]) / (2 * h));
      s[k].push_back(d);
    }
  }
  const Trace nominal = Response(problem, square);
  Eigen::Matrix2d fisher = Eigen::Matrix2d::Zero(), bread = fisher, meat = fisher;
  for (std::size_t c = 0; c < problem.observe.size(); ++c) {
    const auto& y = nominal.Column(problem.observe[c]);
    double mean = 0.0, var = 0.0;
    for (double v : y) mean += v / static_cast<double>(y.size());
    for (double v : y) var += (v - mean) * (v - mean) / static_cast<double>(y.size());
    const double sigma2 = problem.sigma[c] * problem.sigma[c];
    const double a = 1.0 / (2.0 * static_cast<double>(y.size()) * (var + sigma2));
    for (int i = 0; i < 2; ++i) {
      for (int j = 0; j < 2; ++j) {
        double dot = 0.0;
        for (std::size_t n = 0; n < y.size(); ++n) dot += s[i][c][n] * s[j][c][n];
        fisher(i, j) += dot / sigma2;
        bread(i, j) += a * dot;
        meat(i, j) += a * a * sigma2 * dot;
      }
    }
  }
  const Eigen::Matrix2d cramer_rao = fisher.inverse();
  const Eigen::Matrix2d sandwich = bread.inverse() * meat * bread.inverse();
  // The noise weighting (the default): the fit is the maximum-likelihood estimate, its
  // covariance the inverse Fisher information. The variance weighting: the sandwich.
  DesignProblem variance_weighted = problem;
  variance_weighted.config.identification.weighting = "variance";
  const PrecisionPrediction v =
      PredictPrecision(variance_weighted, Response(variance_weighted, square));
  ASSERT_TRUE(v.ok) << v.reason;
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(p.cramer_rao(i, j), cramer_rao(i, j), 1e-6 * std::abs(cramer_rao(i, i)));
      EXPECT_NEAR(p.covariance(i, j), cramer_rao(i, j), 1e-6 * std::abs(cramer_rao(i, i)));
      EXPECT_NEAR(v.cramer_rao(i, j), cramer_rao(i, j), 1e-6 * std::abs(cramer_rao(i, i)));
      EXPECT_NEAR(v.covariance(i, j), sandwich(i, j), 1e-6 * std::abs(sandwich(i, i)));
    }
    EXPECT_DOUBLE_EQ(
        p.ci95_halfwidth[static_cast<std::size_t>(i)],
        Ci95HalfWidth(p.values[static_cast<std::size_t>(i)], std::sqrt(p.covariance(i, i)), true));
  }
  EXPECT_NEAR(p.log_det, std::log(p.covariance.determinant()), 1e-9);
  EXPECT_DOUBLE_EQ(p.peaks.at("u"), 12.0);
}

// One observed column: the cost's weight is a constant factor, so its covariance is the
// inverse Fisher information, and doubling sigma doubles every half-width.
TEST(DesignPrediction, OneColumnIsTheCramerRaoBoundAndScalesWithSigma) {
  DesignProblem problem = Ganesh({"w"});
  const Trace response = Response(problem, problem.config.experiment.input);
  const PrecisionPrediction p = PredictPrecision(problem, response);
  ASSERT_TRUE(p.ok) << p.reason;
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(p.covariance(i, j), p.cramer_rao(i, j), 1e-9 * p.cramer_rao(i, i));
  }
  problem.sigma = {2 * kSigmaW};
  const PrecisionPrediction doubled = PredictPrecision(problem, response);
  ASSERT_TRUE(doubled.ok);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_NEAR(doubled.cramer_rao_ci95_halfwidth[k] / p.cramer_rao_ci95_halfwidth[k], 2.0, 1e-3);
  }
}

TEST(DesignPrediction, NoExcitationIsNamedNotPredicted) {
  const DesignProblem problem = Ganesh();
  InputSignal zero;  // u = 0: nothing moves, every observed column constant
  const PrecisionPrediction p = PredictPrecision(problem, Response(problem, zero));
  EXPECT_FALSE(p.ok);
  EXPECT_NE(p.reason.find("constant"), std::string::npos) << p.reason;
  EXPECT_TRUE(std::isinf(DesignCriterion(p, {})));
}

TEST(DesignPrediction, UnidentifiableParametersAreASingularInformation) {
  // From w alone the servo shows four coefficients of its transfer function, not six.
  Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  config.identification.free = {"R", "L", "Kt", "Kb", "J", "B"};
  DesignProblem problem = MakeDesignProblem(config);
  problem.observe = {"w"};
  problem.sigma = {kSigmaW};
  const PrecisionPrediction p =
      PredictPrecision(problem, Response(problem, config.experiment.input));
  EXPECT_FALSE(p.ok);
  EXPECT_NE(p.reason.find("singular"), std::string::npos) << p.reason;
}

ExperimentDesignOptions Options() {
  ExperimentDesignOptions o;
  o.duration = 2.0;
  o.sample_rate = 2000.0;
  o.input_limit = 12.0;
  return o;
}

TEST(DesignCandidate, AmplitudeLoweredToTheLimitsInThreeDigits) {
  const DesignProblem problem = Ganesh();
  ExperimentDesignOptions options = Options();
  options.output_limits = {{"i", 0.5}, {"theta", 30.0}};
  DesignCandidate square;
  square.family = "square";
  square.input = problem.config.experiment.input;  // 12 V: i peaks at 1.39 A, theta at 105 rad
  const DesignCandidate c = EvaluateCandidate(problem, options, square);
  ASSERT_TRUE(c.feasible) << c.rejected;
  EXPECT_LE(c.prediction.peaks.at("i"), 0.5);
  EXPECT_LE(c.prediction.peaks.at("theta"), 30.0);
  EXPECT_GT(c.prediction.peaks.at("theta"), 0.95 * 30.0);  // lowered no more than needed
  EXPECT_LT(c.input.amplitude, 12.0);
  const double hundredths = c.input.amplitude * 100.0;  // below 10 V: three digits are 0.01 V
  EXPECT_DOUBLE_EQ(hundredths, std::round(hundredths)) << c.input.amplitude;
}

TEST(DesignCandidate, InputAboveTheInputLimitIsLowered) {
  const DesignProblem problem = Ganesh();
  ExperimentDesignOptions options = Options();
  options.input_limit = 6.0;
  DesignCandidate square;
  square.family = "config";
  square.input = problem.config.experiment.input;
  const DesignCandidate c = EvaluateCandidate(problem, options, square);
  ASSERT_TRUE(c.feasible) << c.rejected;
  EXPECT_DOUBLE_EQ(c.input.amplitude, 6.0);
  EXPECT_DOUBLE_EQ(c.prediction.peaks.at("u"), 6.0);
}

TEST(DesignSearch, StepsAreAStaircaseOfEqualStepsWithinTheLimit) {
  const DesignProblem problem = Ganesh();
  ExperimentDesignOptions options = Options();
  options.families = {"steps"};
  const ExperimentDesignResult result = SearchDesign(problem, options);
  ASSERT_TRUE(result.ok) << result.reason;
  const DesignCandidate& best = result.best;
  EXPECT_EQ(best.family, "steps");
  ASSERT_GE(best.levels, 1);
  const double step = best.input.amplitude / best.levels;
  const auto& v = best.input.values;
  ASSERT_GE(v.size(), 2u);
  for (std::size_t k = 0; k < v.size(); ++k) {
    EXPECT_LE(std::abs(v[k]), 12.0);
    EXPECT_NEAR(v[k] / step, std::round(v[k] / step), 1e-9);
    if (k > 0) {
      EXPECT_NEAR(std::abs(v[k] - v[k - 1]), step, 1e-9 * step);
    }
    EXPECT_NEAR(best.input.times[k], static_cast<double>(k) * best.dwell, 1e-12);
  }
  EXPECT_EQ(result.family_best.size(), 1u);
}

TEST(DesignSearch, TheBestIsNoWorseThanAnyFamilysBestNorTheConfigsSquare) {
  const DesignProblem problem = Ganesh();
  const ExperimentDesignResult result = SearchDesign(problem, Options());
  ASSERT_TRUE(result.ok) << result.reason;
  EXPECT_EQ(result.criterion, "D-optimal");
  EXPECT_EQ(result.family_best.size(), 4u);
  for (const auto& c : result.family_best) EXPECT_LE(result.best.criterion, c.criterion);
  DesignCandidate square;
  square.family = "config";
  square.input = problem.config.experiment.input;
  EXPECT_LE(result.best.criterion, EvaluateCandidate(problem, Options(), square).criterion);
  EXPECT_GT(result.evaluated, 150);
  EXPECT_TRUE(result.rejected.empty());
}

TEST(DesignSearch, TargetMinimisesThatParametersVariance) {
  const DesignProblem problem = Ganesh();
  ExperimentDesignOptions options = Options();
  const ExperimentDesignResult d = SearchDesign(problem, options);
  options.target = {"J"};
  const ExperimentDesignResult a = SearchDesign(problem, options);
  ASSERT_TRUE(d.ok && a.ok);
  EXPECT_EQ(a.criterion, "A-optimal");
  EXPECT_DOUBLE_EQ(a.best.criterion, a.best.prediction.covariance(0, 0));
  EXPECT_LE(a.best.prediction.ci95_halfwidth[0], d.best.prediction.ci95_halfwidth[0]);
}

TEST(DesignSearch, BadOptionsAreInputErrors) {
  const DesignProblem problem = Ganesh();
  ExperimentDesignOptions options = Options();
  options.families = {"sine"};
  EXPECT_THROW(SearchDesign(problem, options), InputError);
  options = Options();
  options.target = {"R"};
  EXPECT_THROW(SearchDesign(problem, options), InputError);
}

TEST(DesignProblem, EquationErrorIsRefused) {
  EXPECT_THROW(MakeDesignProblem(LoadConfig(SourcePath("tests/schema/rigid-fit.json"))),
               InputError);
}

TEST(DesignNoise, ResidualRootMeanSquare) {
  EXPECT_DOUBLE_EQ(ResidualNoise({1.0, 2.0, 3.0, 4.0}, {0.0, 2.0, 3.0, 6.0}), std::sqrt(5.0 / 4.0));
}

}  // namespace
}  // namespace blmd::testing
