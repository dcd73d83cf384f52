// Figures a user asks for that are functions of the fitted parameters (an effect's
// EffectInfo::derived: a two-mass shaft's resonance, its two inertias, its stiffness), with
// their 95 % intervals (docs/uncertainty.md, "Derived figures").
//
// The interval is the delta method's (Casella & Berger, Statistical Inference, 2nd ed., 2002,
// §5.5.4) on the covariance the parameters' intervals come from (parameter_correlation.h:
// the prewhitened HAC sandwich, in the search coordinates, ln x for a log-scale parameter):
//   sigma_q^2 = g' Sigma g,   g = dq/d(search coordinates), by central differences,
// and, with the same Student t quantile as the parameters', q exp(+-t sigma_q / q) for a
// positive figure (the interval of ln q, as a log-scale parameter's), q +- t sigma_q otherwise.
// Where the parameters' intervals were widened afterwards (the spread between traces, an
// ambiguity between models), the figure's is not: the report says which method gave it.
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/fit_result.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/uncertainty/parameter_correlation.h"

namespace blmd {

struct DerivedEstimate {
  std::string name;
  std::string effect;  // whose figure it is
  std::string unit;
  std::string meaning;
  double value = 0.0;
  bool has_interval = false;  // std and ci95 valid
  double std = 0.0;
  double ci95_low = 0.0, ci95_high = 0.0;
  std::string interval_method;  // "delta_method"
  std::string reason;           // why there is no interval
};

// Every derived figure of the problem's enabled effects at `result`'s values, in the effects'
// order; with intervals when `correlation` holds the covariance and the fit's intervals ran.
std::vector<DerivedEstimate> EstimateDerived(const FitProblem& problem, const FitResult& result,
                                             const ParameterCorrelation& correlation);

}  // namespace blmd
