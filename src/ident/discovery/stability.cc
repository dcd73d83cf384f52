// The stability check of discovery's decisions on perturbed copies of the data
// (docs/discovery.md §3d); declared in round.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "blmd/format.h"
#include "blmd/random.h"
#include "ident/discovery/round.h"

namespace blmd::internal {
namespace {

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

// The plain BIC of `config` with `free` at `values` on `traces`, scored as the report scores
// it (the measured angle for a position-dependent effect unless effect_angle is
// "simulated"); +inf when it does not simulate.
double PlainBic(const Config& config, const std::vector<FreeParameter>& free,
                const std::vector<FitTrace>& traces, const std::vector<std::string>& observe,
                const std::vector<double>& values) {
  const FitProblem problem(config, traces, observe, free);
  const Evaluation evaluation = problem.Evaluate(values);
  return evaluation.ok ? Bic(problem, evaluation, problem.num_free())
                       : std::numeric_limits<double>::infinity();
}

}  // namespace

// A copy of the data with every measured value, the recorded input and the initial state
// scaled by 1 + relative·z, z standard normal from `seed` (time stays as recorded).
std::vector<FitTrace> PerturbedTraces(const std::vector<FitTrace>& traces, std::uint64_t seed,
                                      double relative) {
  Random random(seed);
  std::vector<FitTrace> out = traces;
  for (FitTrace& f : out) {
    for (std::size_t c = 0; c < f.trace.num_columns(); ++c) {
      if (f.trace.names()[c] == "t") continue;
      for (double& v : f.trace.Column(c)) v *= 1.0 + relative * random.Normal();
    }
    for (double& v : f.input.values) v *= 1.0 + relative * random.Normal();
    for (double* v : {&f.initial.i, &f.initial.w, &f.initial.theta})
      *v *= 1.0 + relative * random.Normal();
  }
  return out;
}

// `values` each scaled by 1 + relative·z (z standard normal from `seed`), kept in their bounds.
std::vector<double> Jittered(std::vector<double> values, const std::vector<FreeParameter>& free,
                             std::uint64_t seed, double relative) {
  Random random(seed);
  for (std::size_t k = 0; k < values.size() && k < free.size(); ++k) {
    values[k] =
        std::clamp(values[k] * (1.0 + relative * random.Normal()), free[k].lower, free[k].upper);
  }
  return values;
}

// Records `o` in result->unstable, replacing an earlier round's outcome of the same effect.
void RecordUnstable(const CandidateOutcome& o, DiscoveryResult* result) {
  auto same = [&](const CandidateOutcome& u) { return u.effect == o.effect; };
  result->unstable.erase(std::remove_if(result->unstable.begin(), result->unstable.end(), same),
                         result->unstable.end());
  result->unstable.push_back(o);
}

// The stability check (DiscoveryOptions::stability_checks, docs/discovery.md §3d): every
// candidate with a screened or refit point is scored again on the perturbed copies; one whose
// plain ΔBIC moves by more than the tolerance is marked unstable (never added), its reason
// saying by how much, and listed in result->unstable.
void CheckStability(const FitProblem& problem, const FitProblem& current, const FitResult& fit,
                    const std::vector<std::vector<FitTrace>>& perturbed,
                    const DiscoveryOptions& options, Round* round, DiscoveryResult* result) {
  if (perturbed.empty()) return;
  const std::vector<std::string>& observe = problem.observe();
  // The current model on the data as given, then on each copy.
  std::vector<double> base = {
      PlainBic(current.config(), current.free(), problem.traces(), observe, fit.values)};
  for (const auto& traces : perturbed)
    base.push_back(PlainBic(current.config(), current.free(), traces, observe, fit.values));
  for (double b : base) {
    if (!std::isfinite(b)) return;  // nothing to compare with
  }
  std::vector<std::size_t> checked;
  for (std::size_t k = 0; k < round->runs.size(); ++k) {
    if (!round->runs[k].screen_values.empty()) checked.push_back(k);
  }
  ForEachItem(checked, ThreadCount(options.refit.threads), [&](std::size_t k) {
    CandidateRun& run = round->runs[k];
    CandidateOutcome& o = run.outcome;
    const std::vector<double>& values = o.fitted ? run.fit.values : run.screen_values;
    o.stability_checked = true;
    o.stability_delta_bic =
        PlainBic(run.config, run.free, problem.traces(), observe, values) - base[0];
    for (std::size_t c = 0; c < perturbed.size(); ++c) {
      const double moved =
          PlainBic(run.config, run.free, perturbed[c], observe, values) - base[c + 1];
      o.stability_perturbed.push_back(moved);
      // Only a move that changes the decision counts: the data and the copy on opposite
      // sides of the evidence threshold, by more than is usual for the score itself (a
      // model with sticking friction moves its score by a few units under any change; a
      // chaotic one by its size). A score past the threshold on both decides alike, however
      // far it moves (a shaft dithering between encoder counts at standstill flips the sign
      // of its speed under any change, and moves a friction's ΔBIC by thousands on either
      // side of -8000).
      const double delta = o.stability_delta_bic;
      const double tolerance =
          std::max(options.stability_tolerance, options.stability_relative * std::abs(delta));
      if ((!std::isfinite(moved) && delta < -options.bic_margin) ||
          ScoreMoveReverses(delta, moved, options.bic_margin, tolerance)) {
        o.stable = false;
      }
    }
  });
  for (std::size_t k : checked) {
    CandidateOutcome& o = round->runs[k].outcome;
    if (o.stable) continue;
    std::string moved;
    for (double d : o.stability_perturbed) moved += (moved.empty() ? "" : ", ") + G(d, 4);
    o.reason = "unstable: a change of the data of " + G(options.stability_perturbation, 2) +
               " of their values moves its plain BIC change from " + G(o.stability_delta_bic, 4) +
               " to " + moved + ", so the record cannot decide it (not added)";
    RecordUnstable(o, result);
  }
}

}  // namespace blmd::internal
