// The record of a fit cut into two contiguous parts, for the checks that fit on one part and
// look at the other: discovery's block cross-validation (docs/discovery.md §3 "Stopping
// rule") and the effect-stability check (adequacy.h). Private to ident.
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd::internal {

struct RecordParts {
  bool ok = false;
  std::string reason;       // why not ok
  std::string description;  // "the two halves of the trace", "the odd and the even traces"
  std::vector<FitTrace> first, second;
};

// With two or more traces: the odd and the even traces (1, 3, 5, ... and 2, 4, ...). With one
// trace: its first and second halves in time; the second half starts from the model's simulated
// state at `values` at its first sample (measured i, w, theta only where the model cannot be
// simulated: the equation error). Each part keeps at least 50 samples.
RecordParts SplitRecord(const FitProblem& problem, const std::vector<double>& values);

}  // namespace blmd::internal
