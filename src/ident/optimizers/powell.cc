#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlopt.hpp>

#include "blmd/error.h"
#include "ident/fit/counting_cost.h"
#include "ident/optimizers/methods.h"

namespace blmd::internal {
namespace {

// Finite stand-in for an infinite cost: NLopt's quadratic models cannot take inf.
constexpr double kFailedCost = 1e30;

struct ObjectiveData {
  CountingCost* cost;
  double best = std::numeric_limits<double>::infinity();
  std::vector<double> best_x;
};

double Objective(const std::vector<double>& x, std::vector<double>& /*grad*/, void* data) {
  auto* d = static_cast<ObjectiveData*>(data);
  const double value = d->cost->ScaledCost(x);
  if (!std::isfinite(value)) return kFailedCost;
  if (value < d->best) {
    d->best = value;
    d->best_x = x;
  }
  return value;
}

std::string ResultName(nlopt::result result) {
  switch (result) {
    case nlopt::SUCCESS:
      return "success";
    case nlopt::STOPVAL_REACHED:
      return "stopval reached";
    case nlopt::FTOL_REACHED:
      return "relative cost change below ftol";
    case nlopt::XTOL_REACHED:
      return "parameter change below xtol";
    case nlopt::MAXEVAL_REACHED:
      return "evaluation budget exhausted";
    case nlopt::MAXTIME_REACHED:
      return "time budget exhausted";
    case nlopt::FAILURE:
      return "failure";
    case nlopt::INVALID_ARGS:
      return "invalid arguments";
    case nlopt::OUT_OF_MEMORY:
      return "out of memory";
    case nlopt::ROUNDOFF_LIMITED:
      return "round-off limited";
    case nlopt::FORCED_STOP:
      return "forced stop";
    default:
      return "code " + std::to_string(static_cast<int>(result));
  }
}

}  // namespace

LocalResult NloptLocal(CountingCost& cost, const std::string& algorithm,
                       const std::vector<double>& start, double initial_step, int max_evaluations,
                       double xtol_abs, double ftol_rel) {
  const unsigned n = static_cast<unsigned>(start.size());
  const nlopt::algorithm which = algorithm == "praxis" ? nlopt::LN_PRAXIS : nlopt::LN_BOBYQA;
  nlopt::opt opt(which, n);
  opt.set_lower_bounds(std::vector<double>(n, 0.0));
  opt.set_upper_bounds(std::vector<double>(n, 1.0));
  ObjectiveData data{&cost, std::numeric_limits<double>::infinity(), start};
  opt.set_min_objective(Objective, &data);
  opt.set_xtol_abs(xtol_abs);
  opt.set_ftol_rel(ftol_rel);
  opt.set_maxeval(max_evaluations);
  // BOBYQA needs upper - lower >= 2 x step; the start is kept inside the box.
  std::vector<double> x = start;
  for (double& v : x) v = std::clamp(v, 0.0, 1.0);
  std::vector<double> step(n);
  for (unsigned k = 0; k < n; ++k) {
    step[k] = std::min(initial_step, 0.5);
    if (which == nlopt::LN_BOBYQA) step[k] = std::min(step[k], std::max(x[k], 1.0 - x[k]) * 0.999);
  }
  opt.set_initial_step(step);
  LocalResult result;
  double minimum = 0.0;
  try {
    const nlopt::result code = opt.optimize(x, minimum);
    result.code = static_cast<int>(code);
    result.message = ResultName(code);
    result.converged =
        code == nlopt::SUCCESS || code == nlopt::FTOL_REACHED || code == nlopt::XTOL_REACHED;
  } catch (const nlopt::roundoff_limited&) {
    result.code = static_cast<int>(nlopt::ROUNDOFF_LIMITED);
    result.message = "round-off limited (the cost is flat to machine precision)";
    result.converged = true;
  } catch (const nlopt::forced_stop&) {
    result.code = static_cast<int>(nlopt::FORCED_STOP);
    result.message = "forced stop";
  } catch (const std::exception& error) {
    result.code = static_cast<int>(nlopt::FAILURE);
    result.message = std::string("NLopt failure: ") + error.what();
  }
  // The best point seen (NLopt returns it too, but not after an exception).
  result.scaled = data.best_x;
  result.cost = data.best;
  for (double& v : result.scaled) v = std::clamp(v, 0.0, 1.0);
  result.evaluations = opt.get_numevals();
  return result;
}

std::vector<std::string> PowellOptimizer::option_names() const {
  return {"algorithm", "initial_step", "xtol", "ftol"};
}

FitResult PowellOptimizer::Minimize(const FitProblem& problem,
                                    const OptimizerOptions& options) const {
  CheckMethodOptions("powell", options.method_options, option_names());
  const nlohmann::json& o = options.method_options;
  const std::string algorithm =
      OptionChoice("powell", o, "algorithm", "bobyqa", {"bobyqa", "praxis"});
  const double initial_step = OptionNumber("powell", o, "initial_step", 0.1, {0.0, 1.0, true});
  const double xtol = OptionNumber("powell", o, "xtol", 1e-8, {0.0, 1.0, true});
  const double ftol = OptionNumber("powell", o, "ftol", 1e-12, {0.0, 1.0, true});
  const int budget = options.max_evaluations > 0 ? options.max_evaluations : 2000;

  const auto started = std::chrono::steady_clock::now();
  CountingCost cost(problem, options.progress);
  // PRAXIS draws random directions from NLopt's global generator: seed it, so a run repeats.
  if (algorithm == "praxis") nlopt::srand(options.seed);
  const LocalResult local = NloptLocal(cost, algorithm, problem.ToScaled(problem.InitialValues()),
                                       initial_step, budget, xtol, ftol);
  FitResult result;
  result.values = problem.FromScaled(local.scaled);
  result.evaluation = problem.Evaluate(result.values);
  result.estimates = MakeEstimates(problem, result.values);
  OptimizerSummary& summary = result.summary;
  summary.method = "powell";
  summary.algorithm = algorithm == "praxis" ? "LN_PRAXIS" : "LN_BOBYQA";
  summary.converged = local.converged && result.evaluation.ok;
  summary.termination = local.message;
  summary.message = "NLopt " + summary.algorithm + ": " + local.message;
  summary.raw_code = local.code;
  summary.iterations = local.evaluations;
  summary.figures = PowellFigures{initial_step, xtol, ftol, budget};
  CheckProgress(problem, &result);
  FinishFit(problem, cost, started, &result);
  return result;
}

}  // namespace blmd::internal
