// The analysis behind blmd-ident's HTML page (report/html/html_report.h), run before the page is
// rendered: each model's simulation of every trace and its cost along each free parameter,
// which the report itself does not hold. The renderer then simulates and evaluates nothing.
#pragma once

#include <cstddef>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/report/html/html_report.h"

namespace blmd {

// One slice per free parameter of `problem` through `values` (see HtmlReportOptions for the
// spacing). Evaluations run on `threads` threads (0: all cores); the result does not depend
// on the thread count.
std::vector<CostSlice> ComputeCostSlices(const FitProblem& problem,
                                         const std::vector<double>& values, int points, double span,
                                         int threads);

// The views of the first fit (`result` on `problem`) and, when `discovery` added effects, of
// its final model (FinalProblem): their simulations and cost slices, as `options` asks.
PageViews AnalysePage(const FitProblem& problem, const FitResult& result,
                      const DiscoveryResult* discovery, const HtmlReportOptions& options);

}  // namespace blmd
