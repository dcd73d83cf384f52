// Private: the one finite-difference Jacobian of the cost's weighted residuals
// (FitProblem::Evaluate), for every user (there had been three): the ceres method's
// steps and intervals, the other methods' intervals (NormalisedResidualJacobian), and
// discovery's one-step Gauss-Newton screening. docs/identification.md §4 gives the step.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd::internal {

class CountingCost;

// Search coordinates: x_k = log(value_k) for a log-scale parameter, value_k otherwise.
std::vector<double> ToSearchCoordinates(const FitProblem& problem,
                                        const std::vector<double>& values);
// Back to values; with `clamp` each value is held within its bounds.
std::vector<double> FromSearchCoordinates(const FitProblem& problem, const std::vector<double>& x,
                                          bool clamp = false);

// How the neighbours of x are placed. The step is the problem's (FitProblem::DifferenceStep)
// unless set: coarse for a fixed-step simulation, whose stick-slip and PWM events shift by
// whole integration steps (the cost has micro-jumps that a step of 1e-6 would differentiate),
// fine for the events integration, whose output is smooth in the parameters.
// Discovery's screening and order ranking difference from effects at zero with a step of
// their own: a coarse one, whatever the integration.
inline constexpr double kScreeningDifferenceStep = 1e-3;

struct DifferenceRule {
  // h = step in log coordinates; linear: step * max(|x|, floor * range). 0: the problem's.
  double step = 0.0;
  double linear_floor = 1e-3;    // the floor, as a fraction of the parameter's bound range
  bool central = true;           // 2p + 1 points; false: forward, p + 1 (+ backward on failure)
  bool clamp_to_bounds = false;  // neighbours held within the bounds (discovery's screening)
  // Where one side of a central difference fails, the other side's one-sided difference
  // stands in; false: any failed neighbour fails the Jacobian.
  bool one_sided_fallback = true;
};

// The weighted residuals at x (search coordinates) and their Jacobian d r / d x (n x p),
// the points simulated together (FitProblem::EvaluateBatch; counted when `counter` is
// given). False when x itself fails, a parameter has no side that succeeds (or, without
// the one-sided fallback, any side fails), or a derivative is not finite (which no solver
// may be handed).
bool FiniteDifferenceJacobian(const FitProblem& problem, const std::vector<double>& x,
                              const DifferenceRule& rule, CountingCost* counter,
                              std::vector<double>* residuals, Eigen::MatrixXd* jacobian);

}  // namespace blmd::internal
