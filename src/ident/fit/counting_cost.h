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

#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"

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

}  // namespace blmd::internal
