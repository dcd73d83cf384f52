#include "blmd/ident/fit/fit_errors.h"

#include <cmath>

namespace blmd {

ErrorFigures ComputeErrors(const FitProblem& problem, const std::vector<double>& values) {
  ErrorFigures errors;
  errors.observe = problem.observe();
  const Evaluation evaluation = problem.Evaluate(values);
  errors.ok = evaluation.ok;
  errors.reason = evaluation.reason;
  if (!evaluation.ok) return errors;
  for (double mse : evaluation.mse) errors.rmse.push_back(std::sqrt(mse));
  errors.mse = evaluation.nrmse2;
  errors.nrmse = std::sqrt(evaluation.nrmse2);
  return errors;
}

std::map<std::string, double> RmseByColumn(const ErrorFigures& errors) {
  std::map<std::string, double> rmse;
  if (!errors.ok) return rmse;
  for (std::size_t c = 0; c < errors.observe.size() && c < errors.rmse.size(); ++c)
    rmse[errors.observe[c]] = errors.rmse[c];
  return rmse;
}

}  // namespace blmd
