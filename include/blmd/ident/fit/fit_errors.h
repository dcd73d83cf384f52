// The error of a parameter set on a set of traces (fit or validation): RMSE per observed
// column and the NRMSE, the figures every report and discovery round quotes.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd {

// The error of a parameter set on a set of traces (fit or validation).
struct ErrorFigures {
  bool ok = false;
  std::string reason;
  std::vector<std::string> observe;
  std::vector<double> rmse;  // per observed column, measured units
  double nrmse = 0.0;        // sqrt(mean_c MSE_c / Var_c)
  double mse = 0.0;          // the cost, = nrmse^2 (dimensionless)
};
ErrorFigures ComputeErrors(const FitProblem& problem, const std::vector<double>& values);

// The RMSE per observed column, by column name (empty when the error was not computed).
std::map<std::string, double> RmseByColumn(const ErrorFigures& errors);

}  // namespace blmd
