// Identification on traces made by the simulator with 1 % noise (sigma = 1 % of the
// column's peak |value|), seeded: the truth is known, so every test has an oracle.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/optimizers/start_scan.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/report/report.h"
#include "blmd/run.h"
#include "support/test_support.h"

namespace blmd {
namespace {

// Simulates the config's experiment and adds 1 % noise to the observed columns.
FitTrace MakeNoisyTrace(const Config& config, const std::vector<std::string>& noisy,
                        std::uint64_t seed, double noise_fraction = 0.01) {
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  Random random(seed);
  for (const auto& column : noisy) {
    double peak = 0.0;
    for (double v : trace.Column(column)) peak = std::max(peak, std::abs(v));
    for (double& v : trace.Column(column)) v += noise_fraction * peak * random.Normal();
  }
  FitTrace fit;
  fit.path = "generated";
  fit.input.kind = InputSignal::Kind::kRecorded;
  fit.input.times = trace.Column("t");
  fit.input.values = trace.Column("u");
  if (trace.Has("open")) fit.input.open = trace.Column("open");
  fit.initial = config.experiment.initial;
  fit.trace = std::move(trace);
  return fit;
}

FitProblem MakeProblem(const Config& config, FitTrace trace,
                       const std::vector<std::string>& observe,
                       const std::vector<std::string>& free_names,
                       const std::vector<double>& initial) {
  Config start = config;
  for (std::size_t k = 0; k < free_names.size(); ++k) {
    start.identification.initial.Set(free_names[k], initial[k]);
  }
  std::vector<FitTrace> traces;
  traces.push_back(std::move(trace));
  return FitProblem(start, std::move(traces), observe, MakeFreeParameters(start, free_names));
}

double RelativeError(double value, double truth) { return std::abs(value / truth - 1.0); }

Config GaneshShort(double duration) {
  Config config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  config.experiment.duration = duration;
  return config;
}

TEST(Identification, DcServoCeresAndPowellRecoverJAndBFromFactorThreeOff) {
  const Config config = GaneshShort(0.6);
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 11);
  for (const auto& [jf, bf] : std::vector<std::pair<double, double>>{
           {3.0, 1.0 / 3.0}, {1.0 / 3.0, 3.0}, {3.0, 3.0}, {1.0 / 3.0, 1.0 / 3.0}}) {
    for (const char* method : {"ceres", "powell"}) {
      const FitProblem problem =
          MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {J * jf, B * bf});
      const FitResult result = FindOptimizer(method).Minimize(problem, OptimizerOptions{});
      SCOPED_TRACE(std::string(method) + " from J x" + std::to_string(jf) + ", B x" +
                   std::to_string(bf));
      EXPECT_TRUE(result.summary.converged) << result.summary.message;
      EXPECT_LT(RelativeError(result.values[0], J), 0.01) << "J = " << result.values[0];
      EXPECT_LT(RelativeError(result.values[1], B), 0.01) << "B = " << result.values[1];
      std::cout << method << " start (x" << jf << ", x" << bf << "): J error "
                << RelativeError(result.values[0], J) * 100 << " %, B error "
                << RelativeError(result.values[1], B) * 100 << " %, " << result.summary.evaluations
                << " evaluations\n";
    }
  }
}

// The issue asks for >= 90 % of 40 seeds. Coverage is a binomial count: measured over 400
// seeds (1000..1399) the true rate is 94.25 % for J and 95.0 % for B, and seeds 1..40 happen
// to give 35/40 for J (a 10 % chance event at that rate). 200 seeds make the verdict stable:
// P(count < 180 | p = 0.94) < 0.2 %. COVERAGE_FIRST / COVERAGE_SEEDS override for studies.
TEST(Identification, CeresIntervalsCoverTheTruthInAtLeast90PercentOfSeeds) {
  const int kFirstSeed =
      std::getenv("COVERAGE_FIRST") ? std::atoi(std::getenv("COVERAGE_FIRST")) : 1;
  const int kSeeds = std::getenv("COVERAGE_SEEDS") ? std::atoi(std::getenv("COVERAGE_SEEDS")) : 200;
  Config config = GaneshShort(0.3);
  config.experiment.sample_rate = 2000.0;
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  int covered_J = 0, covered_B = 0;
  for (int seed = kFirstSeed; seed < kFirstSeed + kSeeds; ++seed) {
    const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, static_cast<std::uint64_t>(seed));
    const FitProblem problem =
        MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {J * 2.0, B * 0.5});
    const FitResult result = FindOptimizer("ceres").Minimize(problem, OptimizerOptions{});
    ASSERT_TRUE(result.estimates[0].has_interval && result.estimates[1].has_interval);
    EXPECT_EQ(result.estimates[0].interval_method, "hac_prewhitened");
    covered_J += result.estimates[0].ci95_low <= J && J <= result.estimates[0].ci95_high;
    covered_B += result.estimates[1].ci95_low <= B && B <= result.estimates[1].ci95_high;
  }
  std::cout << "95 % interval coverage over " << kSeeds << " seeds: J " << covered_J << ", B "
            << covered_B << "\n";
  EXPECT_GE(covered_J, 0.9 * kSeeds);
  EXPECT_GE(covered_B, 0.9 * kSeeds);
}

TEST(Identification, ClassicRecoversJAndBFromACoastDown) {
  Config config = GaneshShort(4.0);
  // Steady by then: the slowest electromechanical pole is -7.9 1/s, e^(-7.9 x 1.5) ~ 7e-6.
  config.experiment.coast_off_time = 1.5;
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 5);
  const FitProblem problem = MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {J * 3, B * 3});
  const FitResult result = FindOptimizer("classic").Minimize(problem, OptimizerOptions{});
  std::cout << "classic: J error " << RelativeError(result.values[0], J) * 100 << " %, B error "
            << RelativeError(result.values[1], B) * 100 << " %\n";
  EXPECT_TRUE(result.summary.converged);
  EXPECT_LT(RelativeError(result.values[0], J), 0.02);
  EXPECT_LT(RelativeError(result.values[1], B), 0.02);
}

// Every optimiser in the registry through the same checks, on one trace each can use (a step
// and a coast-down, so that the classical estimators apply too): it names itself, recovers J
// and B within 2 % from a start a factor of 3 off, gives every free parameter a finite 95 %
// interval that covers the truth (a search; a closed form may give none), counts its cost
// evaluations, and never returns a value
// outside the parameters' bounds. A new registry entry joins the suite without a change here.
class OptimizerRegistrySuite : public ::testing::TestWithParam<std::string> {};

TEST_P(OptimizerRegistrySuite, RecoversJAndBWithIntervalsThatCoverTheTruth) {
  Config config = GaneshShort(4.0);
  config.experiment.coast_off_time = 1.5;
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 5);
  const FitProblem problem = MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {J * 3, B * 3});
  const FitResult result = FindOptimizer(GetParam()).Minimize(problem, OptimizerOptions{});
  EXPECT_EQ(result.summary.method, GetParam());
  EXPECT_TRUE(result.summary.converged) << result.summary.message;
  ASSERT_EQ(result.values.size(), 2u);
  ASSERT_EQ(result.estimates.size(), 2u);
  EXPECT_LT(RelativeError(result.values[0], J), 0.02) << "J = " << result.values[0];
  EXPECT_LT(RelativeError(result.values[1], B), 0.02) << "B = " << result.values[1];
  const double truth[2] = {J, B};
  for (std::size_t k = 0; k < 2; ++k) {
    const ParameterEstimate& e = result.estimates[k];
    SCOPED_TRACE(e.name);
    EXPECT_GE(result.values[k], problem.free()[k].lower);
    EXPECT_LE(result.values[k], problem.free()[k].upper);
    // A closed-form method (one evaluation) may give no interval; a search must.
    if (result.summary.evaluations > 1) {
      ASSERT_TRUE(e.has_interval);
    }
    if (!e.has_interval) continue;
    EXPECT_TRUE(std::isfinite(e.ci95_low) && std::isfinite(e.ci95_high));
    EXPECT_LE(e.ci95_low, truth[k]);
    EXPECT_GE(e.ci95_high, truth[k]);
  }
  EXPECT_GT(result.summary.evaluations, 0);
}

std::vector<std::string> RegisteredMethods() {
  std::vector<std::string> names;
  for (const Optimizer* optimizer : OptimizerRegistry()) names.emplace_back(optimizer->name());
  return names;
}

INSTANTIATE_TEST_SUITE_P(EveryMethod, OptimizerRegistrySuite,
                         ::testing::ValuesIn(RegisteredMethods()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

// The paper's Figs. 8-9 in an optimiser's terms: on the current feedback the cost over J is
// sinc-like, so a local method started outside the central lobe stops in a side lobe while
// FSD finds the global minimum; on the velocity the cost is parabolic and Powell suffices.
class BlmdIdentification : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config_ = new Config(LoadConfig(testing::SourcePath("configs/blmd-d31x.json")));
    trace_ = new FitTrace(MakeNoisyTrace(*config_, {"i", "w"}, 7));
  }
  static void TearDownTestSuite() {
    delete config_;
    delete trace_;
  }
  static Config* config_;
  static FitTrace* trace_;
  // At the side lobe above the truth (a local minimum of the current-feedback cost over J,
  // whose central lobe is about +-8 % wide; see docs/surfaces.md).
  static constexpr double kStartFactor = 1.33;
};
Config* BlmdIdentification::config_ = nullptr;
FitTrace* BlmdIdentification::trace_ = nullptr;

TEST_F(BlmdIdentification, PowellOnCurrentStopsInALocalMinimum) {
  const double J = config_->parameters.Get("J"), B = config_->parameters.Get("B");
  const FitProblem problem =
      MakeProblem(*config_, *trace_, {"i"}, {"J", "B"}, {J * kStartFactor, B});
  const FitResult result = FindOptimizer("powell").Minimize(problem, OptimizerOptions{});
  std::cout << "powell on i from J x" << kStartFactor << ": J = " << result.values[0] << " (error "
            << RelativeError(result.values[0], J) * 100 << " %), NRMSE "
            << std::sqrt(result.evaluation.cost) << "\n";
  EXPECT_GT(RelativeError(result.values[0], J), 0.05);
  EXPECT_GT(std::sqrt(result.evaluation.cost), 0.5);  // a side lobe, far from the noise floor
}

TEST_F(BlmdIdentification, FsdOnCurrentFindsTheGlobalMinimum) {
  const double J = config_->parameters.Get("J"), B = config_->parameters.Get("B");
  const FitProblem problem =
      MakeProblem(*config_, *trace_, {"i"}, {"J", "B"}, {J * kStartFactor, B});
  OptimizerOptions options;
  options.seed = 1;
  const FitResult result = FindOptimizer("fsd").Minimize(problem, options);
  std::cout << "fsd on i from J x" << kStartFactor << ": J = " << result.values[0] << " (error "
            << RelativeError(result.values[0], J) * 100 << " %), B = " << result.values[1]
            << ", NRMSE " << std::sqrt(result.evaluation.cost) << ", " << result.summary.evaluations
            << " evaluations\n";
  EXPECT_LT(RelativeError(result.values[0], J), 0.01);
}

TEST_F(BlmdIdentification, PowellOnVelocityFindsJFromTheSameStart) {
  const double J = config_->parameters.Get("J"), B = config_->parameters.Get("B");
  const FitProblem problem =
      MakeProblem(*config_, *trace_, {"w"}, {"J", "B"}, {J * kStartFactor, B});
  const FitResult result = FindOptimizer("powell").Minimize(problem, OptimizerOptions{});
  std::cout << "powell on w from J x" << kStartFactor << ": J = " << result.values[0] << " (error "
            << RelativeError(result.values[0], J) * 100 << " %)\n";
  EXPECT_TRUE(result.summary.converged);
  EXPECT_LT(RelativeError(result.values[0], J), 0.01);
}

// A position-dependent effect sees the measured angle by default (docs/discovery.md §6): the
// fit and its score of a cogging model do not hinge on where a simulated shaft settles;
// identification.effect_angle "simulated" keeps the free-running angle. Without such an
// effect nothing is forced.
TEST(Identification, PositionDependentEffectsSeeTheMeasuredAngleUnlessAskedOtherwise) {
  Config config = GaneshShort(0.2);
  ParameterSet cogging;
  cogging.Set("Tcog", 0.004);
  cogging.Set("periods", 6.0);
  cogging.Set("phase", 0.0);
  const FitTrace plain = MakeNoisyTrace(config, {"i", "w"}, 7);
  EXPECT_FALSE(
      MakeProblem(config, plain, {"i", "w"}, {"J", "B"}, {2e-5, 2e-5}).effect_angle_forced());
  config.AddEffect("cogging", cogging);
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 7);
  const FitProblem measured = MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {2e-5, 2e-5});
  EXPECT_TRUE(measured.effect_angle_forced());
  config.identification.effect_angle = "simulated";
  const FitProblem simulated = MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {2e-5, 2e-5});
  EXPECT_FALSE(simulated.effect_angle_forced());
  // At the true values the two predictions differ only where the noisy measured angle and the
  // simulated one part: both fit the trace to its 1 % noise.
  const std::vector<double> truth = {config.parameters.Get("J"), config.parameters.Get("B")};
  const Evaluation at_measured = measured.Evaluate(truth);
  const Evaluation at_simulated = simulated.Evaluate(truth);
  ASSERT_TRUE(at_measured.ok && at_simulated.ok);
  EXPECT_LT(std::sqrt(at_measured.nrmse2), 0.05);
  EXPECT_LT(std::sqrt(at_simulated.nrmse2), 0.05);
}

TEST(Identification, FsdIsDeterministicForASeedWhateverTheThreadCount) {
  const Config config = GaneshShort(0.3);
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 3);
  std::vector<double> first;
  for (int threads : {1, 2, 3}) {
    const FitProblem problem = MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {J * 3, B / 3});
    OptimizerOptions options;
    options.seed = 42;
    options.threads = threads;
    const FitResult result = FindOptimizer("fsd").Minimize(problem, options);
    if (first.empty()) {
      first = result.values;
      EXPECT_LT(RelativeError(result.values[0], J), 0.01);
    } else {
      EXPECT_EQ(result.values, first) << "threads = " << threads;
    }
  }
}

TEST(Identification, DivergingPointsGetInfiniteCostWithAReason) {
  Config config = GaneshShort(0.1);
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 1);
  // J so small that the exact step still holds, but R negative is invalid: a reason, no NaN.
  config.identification.bounds["R"] = {-100.0, 100.0};
  std::vector<FitTrace> traces = {trace};
  const FitProblem problem(config, traces, {"i", "w"}, MakeFreeParameters(config, {"R"}));
  const Evaluation evaluation = problem.Evaluate({-5.0});
  EXPECT_FALSE(evaluation.ok);
  EXPECT_TRUE(std::isinf(evaluation.cost));
  EXPECT_EQ(evaluation.reason, "parameter 'R' must be > 0");
}

// The BLMD drive observed in its phase current and speed (the fleet study's drive,
// docs/fleet.md §8), its J 20 % below the start: the phase current is periodic in the rotor
// angle, so from the start the local fit slides to B's upper bound (a side valley); the
// start scan (docs/identification.md §2a) restarts it from the best of 64 points of the box
// and recovers J and B.
Config BlmdFleetDrive() {
  Config config = LoadConfig(testing::SourcePath("configs/blmd-d31x-square.json"));
  config.simulation.method = SimulationMethod::kEvents;
  config.experiment.duration = 0.16;
  config.experiment.sample_rate = 5000;
  return config;
}

TEST(StartScan, BlmdFitFromASideValleyIsRestartedFromTheScan) {
  Config truth = BlmdFleetDrive();
  const double J0 = truth.parameters.Get("J"), B0 = truth.parameters.Get("B");
  truth.parameters.Set("J", 0.8 * J0);
  truth.parameters.Set("B", 0.9 * B0);
  const FitTrace trace = MakeNoisyTrace(truth, {"i", "w"}, 64);
  const FitProblem problem = MakeProblem(BlmdFleetDrive(), trace, {"i", "w"}, {"J", "B"}, {J0, B0});
  const Optimizer& ceres = FindOptimizer("ceres");
  OptimizerOptions options;
  options.threads = 1;
  // Without the scan: the local fit stops on B's upper bound, J off.
  const FitResult local = ceres.Minimize(problem, options);
  EXPECT_EQ(SideValleyReason(problem, local), "B stopped on its bound");
  EXPECT_GT(std::sqrt(local.evaluation.nrmse2), 0.3);
  EXPECT_GT(RelativeError(local.values[1], 0.9 * B0), 1.0) << "B = " << local.values[1];
  StartScanRecord record;
  const FitResult scanned = MinimizeWithStartScan(ceres, problem, options, &record);
  EXPECT_TRUE(record.ran);
  EXPECT_TRUE(record.improved);
  EXPECT_EQ(record.points, 64);
  EXPECT_EQ(record.restarts, 3);
  EXPECT_LT(RelativeError(scanned.values[0], 0.8 * J0), 0.005) << "J = " << scanned.values[0];
  EXPECT_LT(RelativeError(scanned.values[1], 0.9 * B0), 0.05) << "B = " << scanned.values[1];
  EXPECT_LT(std::sqrt(scanned.evaluation.nrmse2), 0.05);
  EXPECT_EQ(SideValleyReason(problem, scanned), "");
  // The report's start is the user's, and the count holds every evaluation made.
  EXPECT_EQ(scanned.estimates[0].initial, J0);
  EXPECT_GT(scanned.summary.evaluations, local.summary.evaluations + 64);
}

// A fit that looks settled runs no scan: the result is the local method's, bit for bit.
TEST(StartScan, SettledFitIsLeftAsTheMethodReturnedIt) {
  const Config config = GaneshShort(0.6);
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitProblem problem = MakeProblem(config, MakeNoisyTrace(config, {"i", "w"}, 11), {"i", "w"},
                                         {"J", "B"}, {2.0 * J, 0.5 * B});
  const FitResult local = FindOptimizer("ceres").Minimize(problem, OptimizerOptions{});
  StartScanRecord record;
  const FitResult scanned =
      MinimizeWithStartScan(FindOptimizer("ceres"), problem, OptimizerOptions{}, &record);
  EXPECT_FALSE(record.ran);
  EXPECT_EQ(record.reason, "");
  EXPECT_EQ(scanned.values, local.values);
  EXPECT_EQ(scanned.summary.evaluations, local.summary.evaluations);
}

// A start three decades and a half above the record's B (a config written for another
// machine): B's default range [start/1000, start*1000] excludes the truth, the fit stops on
// its lower end, and the range is moved to three decades either side of that end
// (docs/identification.md §2b), where the fit finds J and B. A range the config gives is
// never moved.
TEST(RangeMove, DefaultRangeThatExcludesTheOptimumIsMovedPastTheEndItStoppedOn) {
  Config config = GaneshShort(0.6);
  config.identification.bounds.erase("J");
  config.identification.bounds.erase("B");
  const double J = config.parameters.Get("J"), B = config.parameters.Get("B");
  const FitTrace trace = MakeNoisyTrace(config, {"i", "w"}, 13);
  const FitProblem problem =
      MakeProblem(config, trace, {"i", "w"}, {"J", "B"}, {2.0 * J, 3000.0 * B});
  ASSERT_DOUBLE_EQ(problem.free()[1].lower, 3.0 * B);
  const Optimizer& ceres = FindOptimizer("ceres");
  OptimizerOptions options;
  options.threads = 1;
  const FitResult first = MinimizeWithStartScan(ceres, problem, options, nullptr);
  EXPECT_EQ(SideValleyReason(problem, first), "B stopped on its bound");
  const RangeMove move = MoveDefaultRanges(ceres, problem, first, options);
  ASSERT_TRUE(move.problem);
  ASSERT_EQ(move.shifts.size(), 1u);
  EXPECT_EQ(move.shifts[0].name, "B");
  EXPECT_DOUBLE_EQ(move.shifts[0].from_lower, 3.0 * B);
  EXPECT_DOUBLE_EQ(move.shifts[0].to_lower, 3e-3 * B);
  EXPECT_DOUBLE_EQ(move.shifts[0].to_upper, 3000.0 * B);
  EXPECT_EQ(move.problem->free()[0].lower, problem.free()[0].lower);  // J was not moved
  EXPECT_LT(RelativeError(move.fit.values[0], J), 0.01) << "J = " << move.fit.values[0];
  EXPECT_LT(RelativeError(move.fit.values[1], B), 0.01) << "B = " << move.fit.values[1];
  EXPECT_EQ(SideValleyReason(*move.problem, move.fit), "");

  Config given = config;
  given.identification.bounds["B"] = {3.0 * B, 10.0};
  const FitProblem bounded =
      MakeProblem(given, trace, {"i", "w"}, {"J", "B"}, {2.0 * J, 3000.0 * B});
  const FitResult stopped = MinimizeWithStartScan(ceres, bounded, options, nullptr);
  EXPECT_EQ(SideValleyReason(bounded, stopped), "B stopped on its bound");
  EXPECT_FALSE(MoveDefaultRanges(ceres, bounded, stopped, options).problem);
}

}  // namespace
}  // namespace blmd
