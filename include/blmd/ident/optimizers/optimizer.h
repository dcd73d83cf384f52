// Optimisers behind one interface (docs/identification.md): OptimizerOptions in, FitResult
// with its summary out (fit/fit_result.h). One registry knows every method; an unknown name lists
// the valid ones.
//   ceres   - Ceres Solver nonlinear least squares on the per-sample residuals, numeric
//             (central) derivatives, bounds; the prewhitened HAC sandwich for the intervals.
//   powell  - NLopt's Powell family in scaled coordinates: BOBYQA (default) or PRAXIS.
//   fsd     - Fast Simulated Diffusion (our reconstruction, docs/fsd.md), seeded, with a
//             final BOBYQA polish; deterministic for a seed whatever the thread count.
//   classic - Ganesh et al. (2012) estimators on steady-state and coast-down traces.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"

namespace blmd {

class Optimizer {
 public:
  virtual ~Optimizer() = default;
  virtual std::string_view name() const = 0;
  virtual std::vector<std::string> option_names() const = 0;
  virtual FitResult Minimize(const FitProblem& problem, const OptimizerOptions& options) const = 0;
};

const std::vector<const Optimizer*>& OptimizerRegistry();
const Optimizer& FindOptimizer(std::string_view name);

}  // namespace blmd
