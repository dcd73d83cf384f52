// Private: NLopt's local methods in a fit's scaled coordinates, shared by the powell method,
// the FSD polish and discovery's screening.
#pragma once

#include <string>
#include <vector>

#include "ident/fit/counting_cost.h"

namespace blmd::internal {

// BOBYQA/PRAXIS in scaled coordinates from `start`.
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
