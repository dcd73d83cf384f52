// Private: the optimiser classes, known only to the registry in optimizer.cc.
#pragma once

#include <chrono>

#include "blmd/ident/optimizers/optimizer.h"
#include "ident/fit/counting_cost.h"

namespace blmd::internal {

class CeresOptimizer final : public Optimizer {
 public:
  std::string_view name() const override { return "ceres"; }
  std::vector<std::string> option_names() const override;
  FitResult Minimize(const FitProblem& problem, const OptimizerOptions& options) const override;
};

class PowellOptimizer final : public Optimizer {
 public:
  std::string_view name() const override { return "powell"; }
  std::vector<std::string> option_names() const override;
  FitResult Minimize(const FitProblem& problem, const OptimizerOptions& options) const override;
};

class FsdOptimizer final : public Optimizer {
 public:
  std::string_view name() const override { return "fsd"; }
  std::vector<std::string> option_names() const override;
  FitResult Minimize(const FitProblem& problem, const OptimizerOptions& options) const override;
};

class ClassicOptimizer final : public Optimizer {
 public:
  std::string_view name() const override { return "classic"; }
  std::vector<std::string> option_names() const override;
  FitResult Minimize(const FitProblem& problem, const OptimizerOptions& options) const override;
};

// Sets estimate's std and its interval value -+ quantile * std_search (search coordinates:
// ln x for a log-scale parameter, where the interval is value * exp(-+ quantile * sd)).
// quantile: 1.96 for the normal 95 % interval, Student's t for few degrees of freedom.
void SetInterval(const FreeParameter& parameter, double std_search, const std::string& method,
                 ParameterEstimate* estimate, double quantile = 1.959963984540054);
std::vector<ParameterEstimate> MakeEstimates(const FitProblem& problem,
                                             const std::vector<double>& values);

// The end every optimiser's run shares: the evaluation counts and the wall time since
// `started` in the summary.
void CloseSummary(const CountingCost& cost, std::chrono::steady_clock::time_point started,
                  OptimizerSummary* summary);
// CloseSummary, then the intervals at the result when its cost is finite (EstimateUncertainty:
// Powell and FSD; Ceres sets its own from its Jacobian).
void FinishFit(const FitProblem& problem, const CountingCost& cost,
               std::chrono::steady_clock::time_point started, FitResult* result);

}  // namespace blmd::internal
