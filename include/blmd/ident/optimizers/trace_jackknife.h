// Leave-one-trace-out: the spread between traces in the intervals (docs/uncertainty.md §4).
//
// The HAC interval (uncertainty.h) describes how the noise within the traces moves the
// estimate. Real rigs also differ from run to run: the direction, the operating point, the
// temperature, how the load sits. With K >= 3 traces (files, or the blocks of --split) the
// problem is refit K times, each without one trace, from the estimate, and the delete-one
// jackknife variance over traces,
//   var = (K-1)/K sum_k (theta_(k) - mean_k theta_(k))^2
// in search coordinates (ln x for log-scale parameters; Efron & Stein 1981; Efron &
// Tibshirani, An Introduction to the Bootstrap, 1993, ch. 11), treats the traces as the
// independent units and so counts everything that differs between them. The headline
// interval is the wider of the two: the HAC one, or theta +- t_{K-1,0.975} sd_jackknife with
// Student's t for the K-1 degrees of freedom of K traces (Boost.Math).
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"

namespace blmd {

struct TraceJackknife {
  bool ok = false;
  std::string reason;                       // why not ok (fewer than 3 traces, a refit failed)
  int traces = 0;                           // K
  std::vector<double> std_search;           // per free parameter, search coordinates
  std::vector<std::vector<double>> refits;  // per left-out trace: the free values (physical)
};

// Refits `problem` without each of its traces in turn (Ceres, from `values`). Needs K >= 3.
// Each refit reports its evaluations to options.progress and, once done, one StepDone (the
// caller begins the stage, of K steps).
TraceJackknife LeaveOneTraceOut(const FitProblem& problem, const std::vector<double>& values,
                                const OptimizerOptions& options);

// Widens each estimate of `result` whose jackknife interval is wider than its HAC one:
// interval_method "leave_one_trace_out", the HAC interval kept in std_hac / ci95_hac.
// Records the jackknife in result->summary.interval->leave_one_trace_out.
void WidenByTraceJackknife(const FitProblem& problem, const TraceJackknife& jackknife,
                           FitResult* result);

}  // namespace blmd
