// Private: a thread-safe wrapper that counts cost evaluations and their failure reasons, and
// reports each evaluation to a progress observer when one is given.
#pragma once

#include <Eigen/Dense>
#include <atomic>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "blmd/ident/optimizers/optimizer.h"

namespace blmd::internal {

class CountingCost {
 public:
  explicit CountingCost(const FitProblem& problem, ProgressObserver* progress = nullptr)
      : problem_(problem), progress_(progress) {}

  Evaluation Evaluate(const std::vector<double>& values, std::vector<double>* residuals = nullptr) {
    Evaluation evaluation = problem_.Evaluate(values, residuals);
    Count(evaluation);
    return evaluation;
  }
  // Cost at scaled coordinates.
  double ScaledCost(const std::vector<double>& scaled) {
    return Evaluate(problem_.FromScaled(scaled)).cost;
  }
  // Costs at several scaled points, evaluated together (FitProblem::EvaluateBatch: the blmd
  // model simulates them in SIMD lanes); each equals ScaledCost's.
  std::vector<double> ScaledCosts(const std::vector<std::vector<double>>& scaled) {
    std::vector<std::vector<double>> values;
    values.reserve(scaled.size());
    for (const auto& x : scaled) values.push_back(problem_.FromScaled(x));
    std::vector<double> costs;
    for (const Evaluation& evaluation : EvaluateBatch(values)) costs.push_back(evaluation.cost);
    return costs;
  }
  // Evaluate() at several points together (FitProblem::EvaluateBatch), each counted.
  std::vector<Evaluation> EvaluateBatch(const std::vector<std::vector<double>>& values,
                                        std::vector<std::vector<double>>* residuals = nullptr) {
    std::vector<Evaluation> evaluations = problem_.EvaluateBatch(values, residuals);
    for (const Evaluation& evaluation : evaluations) Count(evaluation);
    return evaluations;
  }

  void FillSummary(OptimizerSummary* summary) const {
    summary->evaluations = evaluations_.load();
    summary->failed_evaluations = failed_.load();
    std::lock_guard<std::mutex> lock(mutex_);
    summary->failure_reasons = reasons_;
  }
  const FitProblem& problem() const { return problem_; }
  long evaluations() const { return evaluations_.load(); }

 private:
  void Count(const Evaluation& evaluation) {
    ++evaluations_;
    if (progress_) progress_->Evaluated(evaluation.ok ? evaluation.cost : kInfinity);
    if (!evaluation.ok) {
      ++failed_;
      std::lock_guard<std::mutex> lock(mutex_);
      ++reasons_[evaluation.reason];
    }
  }

  static constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const FitProblem& problem_;
  ProgressObserver* const progress_;
  std::atomic<long> evaluations_{0};
  std::atomic<long> failed_{0};
  mutable std::mutex mutex_;
  std::map<std::string, long> reasons_;
};

// After a local method (ceres, powell) claims convergence: when the fit ended where the cost
// is no lower than at the start values AND the cost does not change when any free parameter
// moves 5 % (in its search coordinate) around the result, the method stopped on a plateau
// (absurd start values: a J so large that the shaft never moves), not at a minimum. Then
// the result is marked not converged, termination "flat cost", with a message naming the
// fix; likewise when the cost is not finite at the start. Costs one evaluation, plus 2p
// only when the fit made no progress.
void CheckProgress(const FitProblem& problem, FitResult* result);

// The cost's weighted residuals (FitProblem::Evaluate) at `values` and their central-
// difference Jacobian in the search coordinates (the step of docs/identification.md §4);
// false when a point fails.
bool NormalisedResidualJacobian(const FitProblem& problem, const std::vector<double>& values,
                                Eigen::MatrixXd* jacobian, Eigen::VectorXd* residuals);

// Moves each estimate's interval (the white one a method computed, if any) to its white
// fields and sets the headline interval from the prewhitened HAC sandwich of the cost's
// weighted residuals r and their Jacobian J
// (interval_method "hac_prewhitened"); records the sandwich's bandwidth, prewhitening gain
// and variance ratios in summary.interval, or why it is unavailable.
void SetSandwichIntervals(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                          const Eigen::VectorXd& residuals, FitResult* result);

// The inverse Fisher information of white Gaussian noise (search coordinates), from the
// cost's weighted residuals r and their Jacobian J: the Cramer-Rao bound of the experiment
// with each trace's column's noise variance (the cost's noise weights when the traces carry
// them, else SSE/(n - p/C) of the residual). Empty when singular.
Eigen::MatrixXd CramerRaoCovariance(const FitProblem& problem, const Eigen::MatrixXd& jacobian,
                                    const Eigen::VectorXd& residuals);

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

// BOBYQA/PRAXIS in scaled coordinates from `start`; shared by powell and the FSD polish.
struct LocalResult {
  std::vector<double> scaled;
  double cost = 0.0;
  int code = 0;
  std::string message;
  bool converged = false;
  long evaluations = 0;
};
LocalResult NloptLocal(CountingCost& cost, const std::string& algorithm,
                       const std::vector<double>& start, double initial_step, int max_evaluations,
                       double xtol_abs, double ftol_rel);

}  // namespace blmd::internal
