// Private: the optimiser classes, known only to the registry in optimizer.cc.
#pragma once

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/ident/optimizers/optimizer.h"
#include "ident/fit/counting_cost.h"
#include "ident/optimizers/nlopt_local.h"
#include "ident/uncertainty/fit_intervals.h"

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

// After a local method (ceres, powell) claims convergence: when the fit ended where the cost
// is no lower than at the start values AND the cost does not change when any free parameter
// moves 5 % (in its search coordinate) around the result, the method stopped on a plateau
// (absurd start values: a J so large that the shaft never moves), not at a minimum. Then
// the result is marked not converged, termination "flat cost", with a message naming the
// fix; likewise when the cost is not finite at the start. Costs one evaluation, plus 2p
// only when the fit made no progress.
void CheckProgress(const FitProblem& problem, FitResult* result);

// Rejects method options that the method does not know (InputError listing valid ones).
void CheckMethodOptions(const std::string& method, const nlohmann::json& options,
                        const std::vector<std::string>& valid);
// The valid values of a numeric method option: [low, high], or (low, high] when low_open.
struct OptionRange {
  double low;
  double high;
  bool low_open = false;
};
// A method option's value (a JSON number, or text that is a whole decimal number), checked
// against its range: otherwise InputError "method ceres: option fd_step=0 must be > 0 and
// <= 0.5" (docs/identification.md lists every option's range). `fallback` when absent.
double OptionNumber(const std::string& method, const nlohmann::json& options, const char* key,
                    double fallback, OptionRange range);
// A whole-number option in [low, high] (no fraction, no overflow).
int OptionWholeNumber(const std::string& method, const nlohmann::json& options, const char* key,
                      int fallback, int low, int high);
// A text option that must be one of `choices` (the message lists them).
std::string OptionChoice(const std::string& method, const nlohmann::json& options, const char* key,
                         const std::string& fallback, const std::vector<std::string>& choices);

}  // namespace blmd::internal
