#include "ident/discovery/screening.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "blmd/sim/effects.h"
#include "ident/fit/counting_cost.h"
#include "ident/fit/jacobian.h"
#include "ident/optimizers/nlopt_local.h"

namespace blmd::internal {
namespace {

// A position-dependent effect (cogging) is fitted with the measured angle (docs/discovery.md,
// "Cogging: the measured angle"): a cogging torque large enough to matter captures the simulated
// shaft in detents at low speed, so with the simulated angle the cost over (Tcog, phase, J, B) is
// rugged and a local fit stays wherever it starts (measured: a start 12 % off in Tcog and 0.4 rad
// in phase does not move). Evaluated at the measured angle, the cogging torque is a known function
// of time for given (Tcog, phase): the response is nearly linear in it and the cost smooth. Fits
// use it; scores (BIC, NRMSE, the report's errors) use the free-running model.
bool UsesMeasuredAngle(const Config& config) {
  return std::any_of(config.effects.begin(), config.effects.end(), [](const std::string& effect) {
    return FindEffect(effect).position_dependent;
  });
}

}  // namespace

FitProblem MakeProblem(const Config& config, const std::vector<FitTrace>& traces,
                       const std::vector<std::string>& observe,
                       const std::vector<FreeParameter>& free) {
  FitProblem problem(config, traces, observe, free);
  // With effect_angle "measured" the problem already sees the measured angle (FitProblem);
  // with "simulated" it is fitted at it all the same. Unchanged without theta or w.
  if (!problem.effect_angle_forced() && UsesMeasuredAngle(config)) problem.ForceEffectAngle();
  return problem;
}

namespace {

// `evaluation`, reported to `progress` (when there is one) as one cost evaluation.
Evaluation Counted(ProgressObserver* progress, Evaluation evaluation) {
  if (progress) progress->Evaluated(evaluation.cost);
  return evaluation;
}

// The cost at `values` as discovery scores it (docs/discovery.md §6): `evaluation` itself,
// unless the config asks for the simulated angle (effect_angle "simulated") and the fit
// used the measured one: then the free-running model's.
Evaluation FreeRunEvaluation(const FitProblem& problem, const std::vector<double>& values,
                             const Evaluation& evaluation) {
  if (!problem.effect_angle_forced() || problem.config().identification.effect_angle != "simulated")
    return evaluation;
  const FitProblem free_run(problem.config(), problem.traces(), problem.observe(), problem.free());
  return free_run.Evaluate(values);
}

// Builds the problem with `effect` added at `effect_values` (free) and `fixed`.
FitProblem CandidateProblem(const FitProblem& base, const std::vector<double>& base_values,
                            const CandidatePlan& plan, const std::vector<double>& effect_values,
                            const std::map<std::string, double>& fixed, Config* config_out,
                            std::vector<FreeParameter>* free_out) {
  Config config = base.config();
  ParameterSet effect_parameters;
  for (std::size_t k = 0; k < plan.free.size(); ++k)
    effect_parameters.Set(plan.free[k].name, effect_values[k]);
  for (const auto& [name, value] : fixed) effect_parameters.Set(name, value);
  config.AddEffect(plan.effect, effect_parameters);
  std::vector<FreeParameter> free = base.free();
  for (std::size_t k = 0; k < free.size(); ++k) {
    free[k].initial = std::clamp(base_values[k], free[k].lower, free[k].upper);
    config.parameters.Set(free[k].name, free[k].initial);
  }
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    FreeParameter p = plan.free[k];
    p.initial = std::clamp(effect_values[k], p.lower, p.upper);
    free.push_back(p);
  }
  *config_out = config;
  *free_out = free;
  return MakeProblem(config, base.traces(), base.observe(), free);
}

// One damped Gauss-Newton step on all free parameters from `values` (the "one-step
// Gauss-Newton fit"): cheap, and it lets J and B move with the new effect, which a scan with
// J and B held cannot. Returns the better of the start and the step. The Jacobian is the
// shared one (ident/fit/jacobian.h) with a coarser floor for linear parameters (1 % of the
// range: an effect's amplitude starts at 0) and the neighbours held within the bounds. Its
// evaluations are reported to `progress` (may be null).
std::pair<std::vector<double>, Evaluation> OneStepGaussNewton(const FitProblem& problem,
                                                              const std::vector<double>& values,
                                                              const Evaluation& start,
                                                              ProgressObserver* progress) {
  const std::size_t p = problem.num_free();
  const std::vector<double> x0 = ToSearchCoordinates(problem, values);
  DifferenceRule rule;
  rule.step = kScreeningDifferenceStep;
  rule.linear_floor = 1e-2;
  rule.clamp_to_bounds = true;
  rule.one_sided_fallback = false;
  std::vector<double> r0;
  Eigen::MatrixXd jacobian;
  internal::CountingCost counter(problem, progress);
  if (!FiniteDifferenceJacobian(problem, x0, rule, &counter, &r0, &jacobian))
    return {values, start};
  const std::size_t n = r0.size();
  const Eigen::Map<const Eigen::VectorXd> residual(r0.data(), static_cast<Eigen::Index>(n));
  Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
  const Eigen::VectorXd gradient = jacobian.transpose() * residual;
  std::vector<double> best_values = values;
  Evaluation best = start;
  for (double damping : {1e-4, 1e-2, 1.0}) {
    Eigen::MatrixXd damped = normal;
    for (Eigen::Index k = 0; k < damped.rows(); ++k) damped(k, k) *= (1.0 + damping);
    const Eigen::VectorXd step = damped.ldlt().solve(-gradient);
    if (!step.allFinite()) continue;
    std::vector<double> x = x0;
    for (std::size_t k = 0; k < p; ++k) x[k] += step(static_cast<Eigen::Index>(k));
    const std::vector<double> trial = FromSearchCoordinates(problem, x, /*clamp=*/true);
    const Evaluation evaluation = Counted(progress, problem.Evaluate(trial));
    if (evaluation.ok && evaluation.cost < best.cost) {
      best = evaluation;
      best_values = trial;
      break;
    }
  }
  return {best_values, best};
}

}  // namespace

namespace {

// The sum of squared differences of two residual vectors (+inf when their sizes differ).
double SquaredDifference(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
  return sum;
}

// The factors a grid may use, from the largest down, at most `count`: those that leave at
// least kMinGridStepsPerSample steps in the traces' shortest sample interval, and divide its
// steps when the sampling is a whole number of steps (else the largest and its halvings).
std::vector<int> GridFactors(const FitProblem& problem, std::size_t count) {
  const double dt = problem.config().simulation.dt;
  double shortest = std::numeric_limits<double>::infinity();
  for (const FitTrace& trace : problem.traces()) {
    const std::vector<double>& t = trace.trace.Column("t");
    for (std::size_t k = 1; k < t.size(); ++k) shortest = std::min(shortest, t[k] - t[k - 1]);
  }
  const double ratio = shortest / dt;
  std::vector<int> factors;
  if (!std::isfinite(ratio) || ratio < 2.0 * kMinGridStepsPerSample || ratio > 1e6) return factors;
  const long whole = std::lround(ratio);
  const bool regular = std::abs(ratio - static_cast<double>(whole)) <= 1e-6 * ratio;
  const auto largest = static_cast<long>(std::floor(ratio / kMinGridStepsPerSample));
  // Uneven sampling has no divisors to follow: the largest, then halving, so that the levels
  // spread as a regular record's divisors do (not 25, 24, 23, 22).
  for (long d = largest; d >= 2; d = regular ? d - 1 : d / 2) {
    if (regular && whole % d != 0) continue;
    factors.push_back(static_cast<int>(d));
    if (factors.size() == count) break;
  }
  return factors;
}

// The candidate at its probe point: the middle of its start points (of its first alternative
// when it has several), an effect of a typical size, where a coarser step's error shows.
bool ProbePoint(const CandidatePlan& plan, std::vector<double>* start,
                std::map<std::string, double>* fixed) {
  if (!plan.applicable) return false;
  if (!plan.starts.empty()) {
    *start = plan.starts[plan.starts.size() / 2];
  } else if (!plan.alternative_starts.empty() && !plan.alternative_starts.front().empty()) {
    *start = plan.alternative_starts.front().front();
  } else {
    return false;
  }
  fixed->clear();
  if (!plan.fixed_alternatives.empty()) *fixed = plan.fixed_alternatives.front();
  return start->size() == plan.free.size();
}

}  // namespace

bool SimulatesOnFixedStep(const FitProblem& problem) {
  return !problem.equation_error() &&
         problem.config().simulation.method == SimulationMethod::kFixedEuler &&
         problem.config().simulation.dt > 0.0;
}

ScreeningGrid ChooseScreeningGrid(const FitProblem& current, const std::vector<double>& values,
                                  double floor_nrmse) {
  ScreeningGrid grid;
  if (!SimulatesOnFixedStep(current)) return grid;
  const double dt = current.config().simulation.dt;
  std::vector<double> fine;
  const Evaluation at_fine = current.Evaluate(values, &fine);
  if (!at_fine.ok) return grid;
  const double noise_cost = current.noise_weighted() ? 1.0 : floor_nrmse * floor_nrmse;
  grid.reference_ = std::min(at_fine.cost, noise_cost);
  if (!(grid.reference_ > 0.0)) return grid;
  for (int factor : GridFactors(current, kMaxGridLevels)) {
    auto coarse = std::make_shared<const FitProblem>(current.WithStep(factor * dt));
    std::vector<double> residuals;
    const Evaluation at = coarse->Evaluate(values, &residuals);
    if (!at.ok || !(SquaredDifference(residuals, fine) <= kGridTolerance * grid.reference_))
      continue;
    grid.levels_.push_back({factor, coarse, Bic(*coarse, at, coarse->num_free())});
  }
  return grid;
}

int ScreeningGrid::CoarsestHolding(const FitProblem& model, const std::vector<double>& values,
                                   ProgressObserver* progress) const {
  std::vector<double> at_fine;
  if (levels_.empty() || !Counted(progress, model.Evaluate(values, &at_fine)).ok) return -1;
  const double dt = model.config().simulation.dt;
  for (int level = 0; level < levels(); ++level) {
    std::vector<double> residuals;
    const Evaluation at =
        Counted(progress, model.WithStep(Step(level, dt)).Evaluate(values, &residuals));
    if (at.ok && SquaredDifference(residuals, at_fine) <= kGridTolerance * reference_) return level;
  }
  return -1;
}

int ScreeningGrid::LevelFor(const FitProblem& fine, const std::vector<double>& values,
                            const CandidatePlan& plan, ProgressObserver* progress) const {
  if (levels_.empty()) return -1;
  std::vector<double> start;
  std::map<std::string, double> fixed;
  if (!ProbePoint(plan, &start, &fixed)) return plan.applicable ? -1 : 0;
  Config config;
  std::vector<FreeParameter> free;
  const FitProblem probe = CandidateProblem(fine, values, plan, start, fixed, &config, &free);
  return CoarsestHolding(probe, probe.InitialValues(), progress);
}

int ScreeningGrid::LevelHolding(const FitProblem& fine, const Config& config,
                                const std::vector<FreeParameter>& free,
                                const std::vector<double>& values) const {
  return CoarsestHolding(MakeProblem(config, fine.traces(), fine.observe(), free), values, nullptr);
}

// Screening: a deterministic scan of the effect's start points (and cogging periods) with
// the other parameters held, then one Gauss-Newton step on all of them. Its evaluations are
// reported to `progress` (may be null).
CandidateRun ScreenCandidate(const FitProblem& base, const std::vector<double>& base_values,
                             const CandidatePlan& plan, double bic_before,
                             ProgressObserver* progress) {
  CandidateRun run;
  run.outcome.effect = plan.effect;
  if (!plan.applicable) {
    run.outcome.reason = plan.not_applicable;
    return run;
  }
  std::vector<std::map<std::string, double>> alternatives = plan.fixed_alternatives;
  if (alternatives.empty()) alternatives.emplace_back();
  // Scan: every start point of every alternative, the other parameters held.
  struct Scanned {
    double cost;
    std::size_t alternative;
    std::vector<double> start;
  };
  std::vector<Scanned> scanned;
  for (std::size_t a = 0; a < alternatives.size(); ++a) {
    std::vector<std::vector<double>> starts = plan.starts;
    if (a < plan.alternative_starts.size()) {
      starts.insert(starts.begin(), plan.alternative_starts[a].begin(),
                    plan.alternative_starts[a].end());
    }
    Scanned best_of_alternative{std::numeric_limits<double>::infinity(), a, {}};
    std::vector<Scanned> of_alternative;
    for (const auto& start : starts) {
      Config config;
      std::vector<FreeParameter> free;
      const FitProblem problem =
          CandidateProblem(base, base_values, plan, start, alternatives[a], &config, &free);
      const Evaluation evaluation = Counted(progress, problem.Evaluate(problem.InitialValues()));
      if (evaluation.ok) of_alternative.push_back({evaluation.cost, a, start});
    }
    // With several alternatives (cogging orders) only each one's best start competes.
    std::stable_sort(of_alternative.begin(), of_alternative.end(),
                     [](const Scanned& l, const Scanned& r) { return l.cost < r.cost; });
    const std::size_t keep = alternatives.size() > 1 ? 1 : 2;
    for (std::size_t k = 0; k < of_alternative.size() && k < keep; ++k)
      scanned.push_back(of_alternative[k]);
  }
  if (scanned.empty()) {
    run.outcome.reason = "every start point failed to simulate";
    return run;
  }
  // The scan holds J and B at values that absorbed the missing effect, so its ranking is
  // rough: the best few (five alternatives, or the two best starts) each get a short local
  // search on all free parameters (BOBYQA; a short Ceres fit at the measured angle for
  // cogging), and the best of those is screened.
  std::stable_sort(scanned.begin(), scanned.end(),
                   [](const Scanned& l, const Scanned& r) { return l.cost < r.cost; });
  if (scanned.size() > 5) scanned.resize(5);
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> best_values;
  std::map<std::string, double> best_fixed;
  for (const auto& candidate : scanned) {
    Config config;
    std::vector<FreeParameter> free;
    const FitProblem problem =
        CandidateProblem(base, base_values, plan, candidate.start,
                         alternatives[candidate.alternative], &config, &free);
    double cost = std::numeric_limits<double>::infinity();
    std::vector<double> values;
    if (problem.effect_angle_forced()) {
      // At the measured angle the cost is smooth: a short Ceres fit settles each order.
      OptimizerOptions short_fit;
      short_fit.threads = 1;
      short_fit.progress = progress;
      short_fit.method_options["max_iterations"] = 10;
      const FitResult fit = FindOptimizer("ceres").Minimize(problem, short_fit);
      if (fit.evaluation.ok) {
        cost = fit.evaluation.cost;
        values = fit.values;
      }
    } else {
      internal::CountingCost counting(problem, progress);
      const internal::LocalResult local = internal::NloptLocal(
          counting, "bobyqa", problem.ToScaled(problem.InitialValues()), 0.05, 40, 1e-6, 1e-6);
      cost = local.cost;
      values = problem.FromScaled(local.scaled);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best_fixed = alternatives[candidate.alternative];
      best_values = values;
    }
  }
  if (best_values.empty()) {
    run.outcome.reason = "the local searches of the scan's best points failed";
    return run;
  }
  const std::vector<double> searched_base(best_values.begin(),
                                          best_values.begin() + static_cast<long>(base.num_free()));
  const std::vector<double> best_start(best_values.begin() + static_cast<long>(base.num_free()),
                                       best_values.end());
  const FitProblem problem =
      CandidateProblem(base, searched_base, plan, best_start, best_fixed, &run.config, &run.free);
  const Evaluation at_start = Counted(progress, problem.Evaluate(problem.InitialValues()));
  auto [values, fitted] = OneStepGaussNewton(problem, problem.InitialValues(), at_start, progress);
  Evaluation evaluation = FreeRunEvaluation(problem, values, fitted);
  if (FindEffect(plan.effect).position_dependent && problem.effect_angle_forced() &&
      run.config.identification.effect_angle == "simulated" && evaluation.ok &&
      !(Bic(problem, evaluation, problem.num_free()) < bic_before)) {
    // Fitted at the measured angle, the point may sit just outside the free-running model's
    // narrow basin (a cogging torque captures the simulated shaft in other detents): a short
    // free-running search from there decides, as the refit's polish does.
    std::vector<FreeParameter> free = run.free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = values[k];
    const FitProblem free_run(run.config, base.traces(), base.observe(), free);
    OptimizerOptions polish;
    polish.threads = 1;
    polish.progress = progress;
    polish.method_options["max_iterations"] = 10;
    const FitResult polished = FindOptimizer("ceres").Minimize(free_run, polish);
    if (polished.evaluation.ok && polished.evaluation.cost < evaluation.cost) {
      values = polished.values;
      evaluation = polished.evaluation;
    }
  }
  run.fixed = best_fixed;
  run.screen_values = values;
  run.screen_bic = Bic(problem, evaluation, problem.num_free()) - bic_before;
  run.outcome.delta_bic = run.screen_bic;
  run.outcome.nrmse = std::sqrt(evaluation.nrmse2);
  return run;
}

}  // namespace blmd::internal
