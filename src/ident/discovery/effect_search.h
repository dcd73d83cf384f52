// How discovery searches for each effect (docs/discovery.md §2): the registry of search
// plans (one entry per effect of sim/effects.h that discovery can add: its free parameters
// with their search boxes, start points, the parameter that must differ from zero, a
// physical constraint) and of the residual diagnostic that points at it. Private to ident.
#pragma once

#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/residual/diagnostics.h"

namespace blmd::internal {

// A candidate's search set-up: free effect parameters with bounds, fixed ones, start points.
struct CandidatePlan {
  std::string effect;
  bool applicable = true;
  std::string not_applicable;
  std::vector<FreeParameter> free;                                // the effect's free parameters
  std::map<std::string, double> fixed;                            // the effect's fixed parameters
  std::vector<std::vector<double>> starts;                        // start values for `free`
  std::vector<std::map<std::string, double>> fixed_alternatives;  // cogging: one per period
  std::vector<std::vector<std::vector<double>>> alternative_starts;  // extra starts per alternative
  std::string amplitude;  // parameter that must differ from zero
  // Physical constraint on the refit's values (all parameters, model and effects): empty
  // when valid, else why not.
  std::function<std::string(const ParameterSet&)> constraint;
  // A check on the refit's residual (the candidate's problem at its fitted values): empty when
  // the effect explains what pointed at it, else why not (two_mass: the residual must stop
  // following the input's past).
  std::function<std::string(const FitProblem&, const std::vector<double>&)> residual_check;
  std::string evidence;  // what chose the plan's set-up (cogging: the order), for the report
  // Per alternative (cogging: per order), what chose it, for the evidence line of the one
  // added ("" when the plan's `evidence` says it all).
  std::vector<std::string> alternative_evidence;
};

// What a plan is made from: the current model's fit and its residual's diagnostics.
struct PlanContext {
  const FitProblem& problem;
  const ResidualAnalysis& analysis;
  const std::vector<double>& values;  // the current fit's free parameters
  double torque_scale;                // N·m, TorqueScale()
  double w_max;                       // rad/s, > 0
  bool observes_i;                    // the current i is among the cost's columns
};

// The residual diagnostic that points at an effect, quoted in its evidence line.
enum class Pointer {
  kSignOfW,          // the residual's mean differs by the sign of w (friction)
  kSignOfI,          // ... by the sign of i (dead time)
  kAnglePeak,        // a peak of the residual's angle spectrum (cogging)
  kAngleDependence,  // the torque balance's dependence on the measured angle (spring, gravity)
  kResidualMean,     // the residual's mean (offsets, loads, drag)
  kInputPast,        // the residual follows the input's past (two_mass: input_residual.h)
};

struct EffectSearch {
  std::string_view effect;  // a name of sim's EffectRegistry()
  CandidatePlan (*plan)(const PlanContext& context);
  Pointer pointer;
};

// A free effect parameter searched over [lower, upper] (on a log scale: ln x), started in the
// middle of its box.
inline FreeParameter Free(const std::string& name, double lower, double upper,
                          bool log_scale = false) {
  FreeParameter p;
  p.name = name;
  p.lower = lower;
  p.upper = upper;
  p.log_scale = log_scale;
  p.initial = log_scale ? std::sqrt(lower * upper) : 0.5 * (lower + upper);
  return p;
}

// two_mass's plan (dynamics_search.cc): offered where the residual follows the input's past.
CandidatePlan PlanTwoMass(const PlanContext& context);

// Every effect discovery can add, in the registry's order.
const std::vector<EffectSearch>& EffectSearchRegistry();
// nullptr when discovery has no plan for `effect`.
const EffectSearch* FindEffectSearch(std::string_view effect);

// The search plan for `effect` on the current model (not applicable, with the reason, when
// the effect has no plan or does not apply to these traces).
CandidatePlan PlanCandidate(const std::string& effect, const FitProblem& problem,
                            const ResidualAnalysis& analysis, const std::vector<double>& values);

// "; w residual mean differs by sign of w (t = -17.2)": the diagnostic that points at
// `effect`, from the column where it is strongest ("" when none does).
// For a periodic effect, `order` is the periods per revolution of the alternative added: the
// line cites that order's peak, and says so when the spectrum's strongest peak differs.
std::string PointingDiagnostic(const std::string& effect, const ResidualAnalysis& analysis,
                               int order = 0);

}  // namespace blmd::internal
