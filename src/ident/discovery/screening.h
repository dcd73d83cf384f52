// Discovery's screening of one candidate (private to ident/discovery): the problem with the
// candidate added, a scan of its start points, short local searches and one Gauss-Newton step
// on every free parameter, scored by BIC against the current model (docs/discovery.md §3).
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/progress.h"
#include "ident/discovery/effect_search.h"

namespace blmd::internal {

// One candidate of a round: its plan's outcome, the model with it, its fit.
struct CandidateRun {
  CandidateOutcome outcome;
  Config config;
  std::vector<FreeParameter> free;
  FitResult fit;
  std::map<std::string, double> fixed;
  std::vector<double> screen_values;  // after the scan and one Gauss-Newton step
  double screen_bic = std::numeric_limits<double>::infinity();  // delta BIC at screening
  bool refitted = false;
};

// The problem over `traces` with `free`, fitted at the measured angle when the config has a
// position-dependent effect (the comment in screening.cc says why).
FitProblem MakeProblem(const Config& config, const std::vector<FitTrace>& traces,
                       const std::vector<std::string>& observe,
                       const std::vector<FreeParameter>& free);

// Screens `plan` against the current model `base` at `base_values` (whose BIC is
// `bic_before`): the scan over its start points with the other parameters held, short local
// searches from the best, then one Gauss-Newton step on all of them. Its evaluations are
// reported to `progress` (may be null).
CandidateRun ScreenCandidate(const FitProblem& base, const std::vector<double>& base_values,
                             const CandidatePlan& plan, double bic_before,
                             ProgressObserver* progress);

}  // namespace blmd::internal
