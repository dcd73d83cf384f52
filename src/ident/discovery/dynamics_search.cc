// Discovery's plan for the dynamics the rigid shaft lacks (docs/effects.md, "Discovery of
// two_mass"): the effects pointed at by the input-residual test (input_residual.h) rather than
// by the residual's dependence on the present state. Part of the registry of
// effect_search.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "blmd/ident/residual/input_residual.h"
#include "blmd/io/csv.h"
#include "blmd/sim/trace.h"
#include "ident/discovery/effect_search.h"

namespace blmd::internal {
namespace {

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

// two_mass (docs/effects.md): a flexible coupling leaves a residual that follows the input's
// past, concentrated near the resonance f_r = f_a sqrt(1 + r), where the rigid model's speed
// misses the two-mass response most. It is tried only where the input-residual test
// (input_residual.h) says so (p < 1e-3 on the fit's residual): elsewhere the rigid shaft
// explains the record and the four-state search would only cost time. The starts: inertia
// ratios 0.3, 1 and 3, each with the anti-resonance that puts f_r at the test's peak frequency
// (and 0.8 .. 1.25 times it: the peak of a fitted 25-lag response is a pointer, not a
// measurement), then a log grid of f_a over the band the samples resolve.
constexpr double kTwoMassGate = 1e-3;

// The input-residual test (input_residual.h) of `problem`'s fit at `values`: its w column's
// residual (else theta's) against the recorded input, pooled over the traces; the shortest
// trace's duration and the sample rate (1 / the longest mean interval) beside it. Not ok
// (with the reason) when the fit is not an output-error fit of w or theta with a recorded u.
struct InputPastOfFit {
  InputPastTest test;
  double duration = 0.0, rate = 0.0;
  std::string not_applicable;
};
InputPastOfFit TestFitAgainstInputPast(const FitProblem& problem,
                                       const std::vector<double>& values) {
  InputPastOfFit out;
  const auto& observe = problem.observe();
  std::size_t column = observe.size();
  for (std::size_t c = 0; c < observe.size(); ++c) {
    if (observe[c] == "w" || (column == observe.size() && observe[c] == "theta")) column = c;
  }
  if (problem.equation_error() || column == observe.size() || !problem.measured(0).Has("u")) {
    out.not_applicable = "needs an output-error fit of w or theta with a recorded input u";
    return out;
  }
  std::vector<double> residual, u;
  std::vector<std::size_t> segments;
  double duration = std::numeric_limits<double>::infinity(), dt_hi = 0.0;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    Trace simulated;
    if (!problem.Simulate(k, values, &simulated).ok()) {
      out.not_applicable = "the current model could not be simulated";
      return out;
    }
    const Trace& measured = problem.measured(k);
    const auto& m = measured.Column(observe[column]);
    const auto& s = simulated.Column(observe[column]);
    const auto& t = measured.Column("t");
    const auto& input = measured.Column("u");
    if (m.size() < 8 || s.size() != m.size()) continue;
    segments.push_back(residual.size());
    for (std::size_t r = 0; r < m.size(); ++r) {
      residual.push_back(m[r] - s[r]);
      u.push_back(input[r]);
    }
    dt_hi = std::max(dt_hi, (t.back() - t.front()) / static_cast<double>(m.size() - 1));
    duration = std::min(duration, t.back() - t.front());
  }
  if (segments.empty() || !(dt_hi > 0.0) || !(duration > 0.0)) {
    out.not_applicable = "needs traces of at least 8 samples";
    return out;
  }
  out.duration = duration;
  out.rate = 1.0 / dt_hi;
  out.test = TestInputPast(residual, u, segments, out.rate, 25);
  return out;
}

}  // namespace

CandidatePlan PlanTwoMass(const PlanContext& context) {
  CandidatePlan plan;
  const InputPastOfFit of_fit = TestFitAgainstInputPast(context.problem, context.values);
  if (!of_fit.not_applicable.empty()) {
    plan.applicable = false;
    plan.not_applicable = of_fit.not_applicable;
    return plan;
  }
  const double duration = of_fit.duration, rate = of_fit.rate;
  const InputPastTest& past = of_fit.test;
  if (!past.ok || !(past.p_value < kTwoMassGate)) {
    plan.applicable = false;
    plan.not_applicable =
        "the residual does not follow the input's past (p = " + G(past.ok ? past.p_value : 1.0, 3) +
        ")";
    return plan;
  }
  // f_a's box: from a few periods over the shortest record to below the Nyquist frequency.
  const double fa_low = std::max(4.0 / duration, 0.1), fa_high = 0.45 * rate;
  plan.free = {Free("inertia_ratio", 0.02, 50.0, /*log_scale=*/true),
               Free("anti_resonance_hz", fa_low, fa_high, /*log_scale=*/true),
               Free("shaft_damping_ratio", 0.0, 1.0), Free("load_damping_share", 0.0, 1.0)};
  auto add_start = [&](double ratio, double fa) {
    if (fa > 1.05 * fa_low && fa < 0.95 * fa_high) plan.starts.push_back({ratio, fa, 0.05, 0.5});
  };
  const double peak = past.frequency_hz;
  if (peak > 0.0) {
    for (double ratio : {0.3, 1.0, 3.0}) {
      for (double f : {0.8, 0.9, 1.0, 1.1, 1.25})
        add_start(ratio, f * peak / std::sqrt(1.0 + ratio));
    }
    plan.evidence = "the residual follows the input's past (p = " + G(past.p_value, 3) + ", " +
                    G(100.0 * past.share, 3) + " % of its variance), most near " + G(peak, 3) +
                    " Hz";
  } else {
    plan.evidence = "the residual follows the input's past (p = " + G(past.p_value, 3) + ", " +
                    G(100.0 * past.share, 3) + " % of its variance)";
  }
  for (double ratio : {0.5, 2.0}) {
    for (int k = 0; k < 10; ++k)
      add_start(ratio, fa_low * std::pow(fa_high / fa_low, (k + 0.5) / 10.0));
  }
  plan.amplitude = "inertia_ratio";
  // The coupling must explain what pointed at it: on the refit's residual the part that follows
  // the input's past must fall below half of what it was (an unmodelled current loop, a
  // saturation or a sensor's filter also make that residual, and a two-mass fit then takes a
  // little of it at some frequency while the rest stays).
  const double share_before = past.share;
  plan.residual_check = [share_before](const FitProblem& refit,
                                       const std::vector<double>& values) -> std::string {
    const InputPastOfFit after = TestFitAgainstInputPast(refit, values);
    if (!after.not_applicable.empty() || !after.test.ok) return "";
    if (after.test.p_value < kTwoMassGate && after.test.share > 0.5 * share_before) {
      return "the residual still follows the input's past after it (" +
             G(100.0 * after.test.share, 3) + " % of its variance, was " +
             G(100.0 * share_before, 3) +
             " %): a flexible coupling does not explain those dynamics";
    }
    return "";
  };
  // A resonance at or above the Nyquist frequency is not seen by the samples: a fit that puts
  // it there has modelled something else (a lag, an aliased ripple).
  plan.constraint = [rate](const ParameterSet& p) -> std::string {
    const double fr = p.Get("anti_resonance_hz") * std::sqrt(1.0 + p.Get("inertia_ratio"));
    if (fr > 0.45 * rate) {
      return "implausible: its resonance " + G(fr, 3) +
             " Hz lies above what the samples resolve (" + G(0.45 * rate, 3) + " Hz)";
    }
    return "";
  };
  return plan;
}

}  // namespace blmd::internal
