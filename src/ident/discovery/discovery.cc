#include "blmd/ident/discovery/discovery.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "blmd/format.h"
#include "blmd/ident/residual/evidence.h"
#include "blmd/sim/effects.h"
#include "ident/discovery/effect_search.h"
#include "ident/discovery/round.h"
#include "ident/discovery/screening.h"
#include "parallel.h"

namespace blmd {
namespace {

using internal::CandidatePlan;
using internal::PlanCandidate;
using internal::PointingDiagnostic;

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }
using internal::CandidateRun;
using internal::CheckStability;
using internal::CrossValidateCandidates;
using internal::ForEachItem;
using internal::MakeProblem;
using internal::PassesEvidence;
using internal::PerturbedTraces;
using internal::Round;
using internal::RoundBase;
using internal::ScreenCandidate;

// The share of what `before` leaves above the noise floor that `after` explains (all in
// NRMSE units); 0 when the model before is already at the floor.
double ExplainedShare(double before, double after, double floor) {
  const double above = before * before - floor * floor;
  if (!(above > 0.0)) return 0.0;
  return (before * before - after * after) / above;
}

// Full refit (Ceres, all free parameters) from the screening point, and the verdict.
RoundBase MakeRoundBase(const FitProblem& base, const std::vector<double>& values,
                        double floor_nrmse, const DiscoveryOptions& options) {
  RoundBase round;
  // The model's error as every candidate's is scored (FitProblem: the measured angle for a
  // position-dependent effect unless effect_angle is "simulated").
  const FitProblem free_run(base.config(), base.traces(), base.observe(), base.free());
  round.nrmse = std::sqrt(free_run.Evaluate(values).nrmse2);
  round.floor_nrmse = floor_nrmse;
  const bool held_out = options.held_out && !options.held_out->empty();
  if (!held_out && options.prewhiten && !free_run.Evaluate(values, &round.residuals).ok) {
    round.residuals.clear();
  }
  if (held_out) {
    std::vector<std::string> names;
    for (const auto& f : base.free()) names.push_back(f.name);
    const FitProblem held(base.config(), *options.held_out, base.observe(),
                          NamedFreeParameters(names));
    round.held_out = held.Evaluate(values);
  }
  return round;
}

// The refit runs on `screening_dt`, the step the candidate was screened on, first, when that
// is coarser than the config's (docs/discovery.md §3c): its evaluations are cheaper, and the
// fit on the config's step then starts next to its minimum and is given kPolishIterations
// (the user's --option max_iterations still wins), when that start is better there than the
// screening point.
constexpr int kPolishIterations = 5;
void RefitCandidate(const FitProblem& base, const RoundBase& round, const CandidatePlan& plan,
                    double bic_before, const DiscoveryOptions& options, double screening_dt,
                    CandidateRun* run) {
  for (std::size_t k = 0; k < run->free.size(); ++k) run->free[k].initial = run->screen_values[k];
  OptimizerOptions refit = options.refit;
  refit.default_max_iterations = 50;  // unless the user's --option max_iterations says otherwise
  if (screening_dt > run->config.simulation.dt) {
    const FitProblem fine = MakeProblem(run->config, base.traces(), base.observe(), run->free);
    const FitResult first = FindOptimizer("ceres").Minimize(fine.WithStep(screening_dt), refit);
    // Kept only when it is better on the config's step too than the screening point (else
    // the grid misled this candidate: the full refit from the screening point, as without it).
    if (first.evaluation.ok &&
        fine.Evaluate(first.values).cost < fine.Evaluate(run->screen_values).cost) {
      for (std::size_t k = 0; k < run->free.size(); ++k) run->free[k].initial = first.values[k];
      refit.default_max_iterations = kPolishIterations;
    }
  }
  const FitProblem problem = MakeProblem(run->config, base.traces(), base.observe(), run->free);
  run->fit = FindOptimizer("ceres").Minimize(problem, refit);
  if (run->fit.evaluation.ok && problem.effect_angle_forced() &&
      run->config.identification.effect_angle == "simulated") {
    // Fitted at the measured angle, scored free running (effect_angle "simulated"): polish on
    // the free-running model from there (its basin is narrow but the measured-angle fit lands
    // in it), keeping whichever runs better.
    std::vector<FreeParameter> free = run->free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = run->fit.values[k];
    const FitProblem free_run(run->config, base.traces(), base.observe(), free);
    const Evaluation at_forced = free_run.Evaluate(run->fit.values);
    OptimizerOptions polish = refit;
    polish.method_options["max_iterations"] = 20;
    FitResult polished = FindOptimizer("ceres").Minimize(free_run, polish);
    if (polished.evaluation.ok && (!at_forced.ok || polished.evaluation.cost < at_forced.cost)) {
      run->fit = std::move(polished);
    } else {
      run->fit.evaluation = at_forced;
    }
    // The screening point may already be a free-running search's result (ScreenCandidate)
    // that the measured-angle fit left: polish from it too and keep the better.
    const Evaluation at_screen = free_run.Evaluate(run->screen_values);
    if (at_screen.ok && at_screen.cost < run->fit.evaluation.cost) {
      for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = run->screen_values[k];
      const FitProblem from_screen(run->config, base.traces(), base.observe(), free);
      FitResult again = FindOptimizer("ceres").Minimize(from_screen, polish);
      if (again.evaluation.ok && again.evaluation.cost < run->fit.evaluation.cost)
        run->fit = std::move(again);
    }
  }
  run->outcome.fitted = run->fit.evaluation.ok;
  if (!run->outcome.fitted) {
    run->outcome.reason = "refit failed: " + run->fit.evaluation.reason;
    return;
  }
  run->outcome.bic = Bic(problem, run->fit.evaluation, problem.num_free());
  run->outcome.delta_bic = run->outcome.bic - bic_before;
  run->outcome.delta_bic_white = run->outcome.delta_bic;
  // The evidence counts what correlated samples are worth (evidence.h): the same change in
  // BIC on residuals whitened by the candidate model's AR noise model.
  // With held-out traces the evidence is theirs instead: the plain BIC on the fit traces,
  // and a lower error on traces the effect was not fitted to.
  run->outcome.evidence_rule = "plain_bic";
  if (options.held_out && !options.held_out->empty()) {
    std::vector<std::string> names;
    for (const auto& f : run->free) names.push_back(f.name);
    const FitProblem held_candidate(run->config, *options.held_out, base.observe(),
                                    NamedFreeParameters(names));
    const Evaluation after = held_candidate.Evaluate(run->fit.values);
    run->outcome.evidence_rule = "held_out";
    run->outcome.has_held_out = round.held_out.ok && after.ok;
    if (run->outcome.has_held_out) {
      run->outcome.held_out_before = std::sqrt(round.held_out.nrmse2);
      run->outcome.held_out_after = std::sqrt(after.nrmse2);
      run->outcome.held_out_better = run->outcome.held_out_after <
                                     (1.0 - options.held_out_margin) * run->outcome.held_out_before;
    } else {
      run->outcome.held_out_better = false;
    }
  } else if (options.prewhiten && !round.residuals.empty()) {
    const FitProblem model(run->config, base.traces(), base.observe(), run->free);
    const WhitenedEvidence evidence =
        PrewhitenedEvidence(round.residuals, base.num_free(), model, run->fit.values);
    if (evidence.ok) {
      run->outcome.evidence_rule = "prewhitened_bic";
      run->outcome.delta_bic = evidence.delta_bic;
      run->outcome.bic = bic_before + evidence.delta_bic;
      for (std::size_t c = 0; c < base.observe().size(); ++c) {
        run->outcome.noise_model[base.observe()[c]] = {evidence.order[c],
                                                       evidence.innovation_ratio[c]};
      }
    }
  }
  run->outcome.nrmse = std::sqrt(run->fit.evaluation.nrmse2);
  run->outcome.explained_share = ExplainedShare(round.nrmse, run->outcome.nrmse, round.floor_nrmse);
  run->outcome.material = run->outcome.explained_share >= options.min_explained_share;
  // A deterministic residual that the whitening filter absorbed (DiscoveryOptions::
  // deterministic_share): the plain BIC carries it if the record's parts confirm it.
  run->outcome.deterministic = run->outcome.evidence_rule == "prewhitened_bic" &&
                               !(run->outcome.delta_bic < -options.bic_margin) &&
                               run->outcome.delta_bic_white < -options.bic_margin &&
                               run->outcome.explained_share >= options.deterministic_share;
  const std::size_t offset = base.num_free();
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    run->outcome.parameters[plan.free[k].name] = run->fit.values[offset + k];
  }
  for (const auto& [name, value] : run->fixed) run->outcome.parameters[name] = value;
  for (std::size_t k = 0; k < run->free.size() && k < run->fit.values.size(); ++k) {
    run->outcome.model_parameters[run->free[k].name] = run->fit.values[k];
  }
  // Physical validity: off the search bounds, and the amplitude distinguishable from zero.
  run->outcome.valid = true;
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    const FreeParameter& p = plan.free[k];
    if (IsPeriodicParameter(p.name)) continue;  // a phase wraps: no bound to sit on
    if (IsShareParameter(p.name)) continue;     // a share's ends are findings (all on one side)
    const double v = run->fit.values[offset + k];
    const double margin = 1e-3 * (p.log_scale ? std::log(p.upper / p.lower) : (p.upper - p.lower));
    const double below = p.log_scale ? std::log(v / p.lower) : v - p.lower;
    const double above = p.log_scale ? std::log(p.upper / v) : p.upper - v;
    if (below < margin || above < margin) {
      run->outcome.valid = false;
      run->outcome.reason = p.name + " = " + G(v) + " sits on its search bound [" + G(p.lower) +
                            ", " + G(p.upper) + "]";
      break;
    }
    if (p.name == plan.amplitude) {
      const ParameterEstimate& e = run->fit.estimates[offset + k];
      if (e.has_interval && std::abs(v) < 2.0 * e.std) {
        run->outcome.valid = false;
        run->outcome.reason =
            p.name + " = " + G(v) + " is within two standard deviations (" + G(e.std) + ") of zero";
        break;
      }
    }
  }
  if (run->outcome.valid && plan.constraint) {
    ParameterSet values = run->config.parameters;
    for (std::size_t k = 0; k < run->free.size(); ++k)
      values.Set(run->free[k].name, run->fit.values[k]);
    if (std::string why = plan.constraint(values); !why.empty()) {
      run->outcome.valid = false;
      run->outcome.reason = why;
    }
  }
  if (run->outcome.valid && plan.residual_check) {
    const FitProblem model(run->config, base.traces(), base.observe(), run->free);
    if (std::string why = plan.residual_check(model, run->fit.values); !why.empty()) {
      run->outcome.valid = false;
      run->outcome.reason = why;
    }
  }
  if (run->outcome.valid && !(run->outcome.delta_bic < -options.bic_margin) &&
      !run->outcome.deterministic) {
    run->outcome.reason = "BIC does not fall by more than " + G(options.bic_margin);
  } else if (run->outcome.valid && !run->outcome.material) {
    run->outcome.reason = "tried, not needed: explains " +
                          G(100.0 * run->outcome.explained_share, 2) +
                          " % of the residual above the noise floor (needs " +
                          G(100.0 * options.min_explained_share, 2) + " %)";
  } else if (run->outcome.valid && !run->outcome.held_out_better) {
    run->outcome.reason = run->outcome.has_held_out
                              ? "the held-out NRMSE does not fall by more than " +
                                    G(100.0 * options.held_out_margin) + " % (" +
                                    G(run->outcome.held_out_before) + " -> " +
                                    G(run->outcome.held_out_after) + ")"
                              : "the held-out traces could not be simulated with the effect";
  }
}

std::string Evidence(const std::string& effect, const ResidualAnalysis& analysis,
                     const CandidateOutcome& outcome, double nrmse_before, int order) {
  std::string text =
      outcome.deterministic
          ? "BIC " + G(outcome.delta_bic_white, 5) + " counting every sample (" +
                G(outcome.delta_bic, 5) +
                " on whitened residuals, whose noise model absorbs this deterministic residual)"
          : "BIC " + G(outcome.delta_bic, 5) +
                (outcome.evidence_rule == "prewhitened_bic" &&
                         G(outcome.delta_bic_white, 5) != G(outcome.delta_bic, 5)
                     ? " on whitened residuals (" + G(outcome.delta_bic_white, 5) +
                           " counting every sample)"
                     : std::string()) +
                ", NRMSE " + G(nrmse_before) + " -> " + G(outcome.nrmse) +
                (outcome.has_held_out ? ", held-out NRMSE " + G(outcome.held_out_before) + " -> " +
                                            G(outcome.held_out_after)
                                      : std::string());
  if (outcome.explained_share >= 0.0)
    text += ", explains " + G(100.0 * outcome.explained_share, 3) +
            " % of the residual above the noise floor";
  if (outcome.cross_validated)
    text += ", cross-validated NRMSE " + G(outcome.cv_before) + " -> " + G(outcome.cv_after);
  text += PointingDiagnostic(effect, analysis, order);
  return text;
}

}  // namespace

double Bic(const FitProblem& problem, const Evaluation& evaluation, std::size_t k) {
  double bic = 0.0;
  std::size_t total = 0;
  for (std::size_t c = 0; c < problem.observe().size(); ++c) {
    std::size_t n = 0;
    for (std::size_t t = 0; t < problem.traces().size(); ++t) n += problem.measured(t).rows();
    total += n;
    // An MSE below 1e-12 of the column's variance (NRMSE 1e-6) is the simulator's numerical
    // precision, not a better fit: without this floor a noise-free trace's residual of
    // rounding errors let any effect "explain" part of it (a current offset of 1e-12 A).
    const double floor = std::max(1e-12 * problem.variance()[c], 1e-300);
    bic += static_cast<double>(n) * std::log(std::max(evaluation.mse[c], floor));
  }
  return bic + static_cast<double>(k) * std::log(static_cast<double>(total));
}

namespace {

// The effects a round tries: the user's list, else every effect declared for the model.
std::vector<std::string> CandidateEffects(const DiscoveryOptions& options,
                                          const std::string& model) {
  if (!options.candidates.empty()) return options.candidates;
  std::vector<std::string> candidates;
  for (const auto& effect : EffectRegistry()) {
    if (std::find(effect.models.begin(), effect.models.end(), model) != effect.models.end()) {
      candidates.push_back(effect.name);
    }
  }
  return candidates;
}

// Plans every candidate not yet in the model, screens each with one Gauss-Newton step, refits
// the promising ones and orders them best first. False when no candidate is left to try.
bool ScreenAndRefit(const FitProblem& current, const FitResult& fit, double current_bic,
                    const std::vector<std::string>& candidates, const ResidualAnalysis& analysis,
                    double noise_floor_nrmse, const DiscoveryOptions& options, Round* round) {
  std::vector<CandidatePlan>& plans = round->plans;
  const auto& declared = current.config().effects;
  bool any = false;
  for (const auto& effect : candidates)
    any = any || std::find(declared.begin(), declared.end(), effect) == declared.end();
  if (!any) return false;
  // The screening grids the current model allows (screening.h); each candidate is planned
  // and screened on the coarsest that also simulates it faithfully.
  round->grid = internal::ChooseScreeningGrid(current, fit.values, noise_floor_nrmse);
  const internal::ScreeningGrid& grid = round->grid;
  const FitProblem& planning = grid.Problem(grid.Coarsest(), current);
  for (const auto& effect : candidates) {
    if (std::find(declared.begin(), declared.end(), effect) != declared.end()) continue;
    plans.push_back(PlanCandidate(effect, planning, analysis, fit.values));
  }
  std::vector<CandidateRun>& runs = round->runs;
  runs.resize(plans.size());
  round->levels.assign(plans.size(), -1);
  const int threads = internal::ThreadCount(options.refit.threads);
  std::vector<std::size_t> all(plans.size());
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = k;
  ProgressObserver* const progress = options.refit.progress;
  const std::string round_name = "discovery round " + std::to_string(round->number);
  if (progress) progress->BeginStage(round_name + ": screening", static_cast<int>(plans.size()));
  const bool fixed_step = internal::SimulatesOnFixedStep(current);
  ForEachItem(all, threads, [&](std::size_t k) {
    const int level = grid.LevelFor(current, fit.values, plans[k], progress);
    const FitProblem& screening = grid.Problem(level, current);
    if (&screening != &planning)
      plans[k] = PlanCandidate(plans[k].effect, screening, analysis, fit.values);
    round->levels[k] = level;
    runs[k] =
        ScreenCandidate(screening, fit.values, plans[k], grid.Bic(level, current_bic), progress);
    if (fixed_step) runs[k].outcome.screening_step = screening.config().simulation.dt;
    // The refit simulates on the config's own step.
    runs[k].config.simulation.dt = current.config().simulation.dt;
    if (progress) progress->StepDone();
  });
  round->base = MakeRoundBase(current, fit.values, noise_floor_nrmse, options);
  // Refit the most promising candidates by their screening BIC (deterministic order).
  // Only candidates whose screening already lowers BIC are worth a full refit.
  std::vector<std::size_t> screened;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (!runs[k].screen_values.empty() && runs[k].screen_bic < 0.0) screened.push_back(k);
  }
  std::stable_sort(screened.begin(), screened.end(), [&](std::size_t l, std::size_t r) {
    return runs[l].screen_bic < runs[r].screen_bic;
  });
  // The best `refits`, and every position-dependent candidate (cogging, gravity, spring)
  // whose screening lowers BIC: their screening is the least reliable (a narrow
  // free-running basin around the measured-angle fit), and behind slow candidates that
  // bend the simulation a little everywhere a cogging ripple was never refit (a case:
  // Coulomb friction beside cogging, gravity added in its place).
  std::vector<std::size_t> refit;
  for (std::size_t q = 0; q < screened.size(); ++q) {
    if (q < static_cast<std::size_t>(options.refits) ||
        FindEffect(plans[screened[q]].effect).position_dependent)
      refit.push_back(screened[q]);
  }
  if (progress && !refit.empty())
    progress->BeginStage(round_name + ": refits", static_cast<int>(refit.size()));
  ForEachItem(refit, threads, [&](std::size_t k) {
    RefitCandidate(current, round->base, plans[k], current_bic, options,
                   grid.Step(round->levels[k], current.config().simulation.dt), &runs[k]);
    runs[k].refitted = true;
    if (progress) progress->StepDone();
  });
  for (auto& run : runs) {
    if (!run.refitted && !run.screen_values.empty()) {
      run.outcome.reason = run.screen_bic >= 0.0
                               ? "screened out: one Gauss-Newton step does not lower BIC (" +
                                     G(run.screen_bic, 4) + ")"
                               : "screened out (one-step BIC " + G(run.screen_bic, 4) +
                                     "; only the best " + std::to_string(options.refits) +
                                     " are refit)";
    }
  }
  // Best first: fitted before not, then by BIC; ties by name (deterministic).
  std::vector<std::size_t>& order = round->order;
  order.resize(runs.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t l, std::size_t r) {
    const auto& a = runs[l].outcome;
    const auto& b = runs[r].outcome;
    if (a.fitted != b.fitted) return a.fitted;
    if (a.fitted && a.bic != b.bic) return a.bic < b.bic;
    if (!a.fitted && runs[l].screen_bic != runs[r].screen_bic)
      return runs[l].screen_bic < runs[r].screen_bic;
    return a.effect < b.effect;
  });
  return true;
}

// The candidates that qualify, best first, after parsimony and generalisation: the best by BIC
// gives way to another qualifying one with fewer parameters unless it predicts the data they
// were not fitted to better (by the margin: a Stribeck curve must show its dip, not reshape a
// Coulomb friction), and to one with as many parameters that predicts those data better by
// the margin (a case: gravity's one period per revolution ahead of a cogging ripple by BIC,
// the cogging 2 % better on the held-out blocks).
std::vector<std::size_t> QualifyingCandidates(const DiscoveryOptions& options, Round* round) {
  std::vector<CandidateRun>& runs = round->runs;
  std::vector<std::size_t> qualifying;
  for (std::size_t k : round->order) {
    CandidateOutcome& o = runs[k].outcome;
    if (!PassesEvidence(o, options) || !o.generalises) continue;
    if (o.deterministic && !o.cross_validated) {  // nothing confirmed it (§3a)
      if (o.reason.empty()) {
        o.reason = "its BIC changes by " + G(o.delta_bic_white, 5) +
                   " counting every sample but by " + G(o.delta_bic, 5) +
                   " on whitened residuals, and it was not cross-validated (not added)";
      }
      continue;
    }
    qualifying.push_back(k);
  }
  auto out_of_sample = [&](const CandidateOutcome& o) {
    if (o.cross_validated) return o.cv_after;
    if (o.has_held_out) return o.held_out_after;
    return std::numeric_limits<double>::quiet_NaN();
  };
  if (qualifying.size() <= 1) return qualifying;
  const std::size_t first = qualifying.front();
  for (std::size_t q = 1; q < qualifying.size(); ++q) {
    const std::size_t other = qualifying[q];
    const double first_score = out_of_sample(runs[first].outcome);
    const double other_score = out_of_sample(runs[other].outcome);
    const std::size_t first_size = round->plans[first].free.size();
    const std::size_t other_size = round->plans[other].free.size();
    if (other_size > first_size || !std::isfinite(first_score) || !std::isfinite(other_score))
      continue;
    const bool simpler = other_size < first_size;
    const bool gives_way =
        internal::GivesWay(first_score, other_score, simpler, options.held_out_margin);
    // The same choice on each perturbed copy (docs/discovery.md §3d): one that a change of
    // the data far below their noise reverses is no finding, and the two are reported as
    // models that explain the data equally well (RecordAmbiguity), the choice named.
    const CandidateOutcome& f = runs[first].outcome;
    const CandidateOutcome& g = runs[other].outcome;
    // So is one that the copies scatter too widely to hold (internal::CheckSide).
    const std::optional<std::size_t> reversing =
        internal::FirstCopyReversingChoice(f, g, simpler, options.held_out_margin);
    const internal::SideCheck held =
        f.cross_validated && g.cross_validated
            ? internal::CheckRatio(internal::ChoiceRatios(f, g, simpler),
                                   1.0 - options.held_out_margin)
            : internal::SideCheck{};
    const std::string which = "which of " + f.effect + " and " + g.effect +
                              " predicts the data they were not fitted to better hinges on the "
                              "data's last bits (cross-validated NRMSE " +
                              G(first_score) + " against " + G(other_score) + " on the data, ";
    if (reversing) {
      const std::size_t c = *reversing;
      round->undecided.push_back({first, other});
      round->undecided_reason = which + G(f.cv_perturbed[c]) + " against " + G(g.cv_perturbed[c]) +
                                " on a copy changed by " + G(options.stability_perturbation, 2) +
                                " of its values)";
    } else if (!held.holds) {
      std::string copies;
      for (std::size_t c = 0; c < std::min(f.cv_perturbed.size(), g.cv_perturbed.size()); ++c)
        copies += (copies.empty() ? "" : ", ") + G(f.cv_perturbed[c]) + " against " +
                  G(g.cv_perturbed[c]);
      round->undecided.push_back({first, other});
      round->undecided_reason =
          which + copies + " on copies changed by " + G(options.stability_perturbation, 2) +
          " of their values: a further copy's ratio could lie anywhere from " + G(held.low) +
          " to " + G(held.high) + ", across the margin's " + G(1.0 - options.held_out_margin) + ")";
    }
    if (!gives_way) continue;
    runs[first].outcome.reason =
        simpler ? "tried, not needed: its " + std::to_string(first_size) +
                      " parameters do not predict the data they were not fitted to better "
                      "than " +
                      runs[other].outcome.effect + "'s " + std::to_string(other_size) + " (" +
                      G(first_score) + " against " + G(other_score) + ")"
                : "tried, not needed: " + runs[other].outcome.effect +
                      ", with as many parameters, predicts the data they were not fitted "
                      "to better by more than " +
                      G(100.0 * options.held_out_margin) + " % (" + G(other_score) + " against " +
                      G(first_score) + ")";
    qualifying.erase(qualifying.begin());
    std::stable_sort(qualifying.begin(), qualifying.end(), [&](std::size_t l, std::size_t r) {
      if (l == other) return r != other;
      return false;
    });
    break;
  }
  return qualifying;
}

// The qualifying candidates whose BIC is within the ambiguity margin of the best: recorded in
// `result` (the models, their names and what would tell them apart) when there are several.
// Returns the names beside the best.
std::vector<std::string> RecordAmbiguity(const Round& round,
                                         const std::vector<std::size_t>& qualifying,
                                         const ResidualAnalysis& analysis,
                                         const DiscoveryOptions& options, DiscoveryResult* result) {
  const CandidateRun& best = round.runs[qualifying.front()];
  std::vector<std::string> tied = {best.outcome.effect};
  bool by_bic = false;
  for (std::size_t q = 1; q < qualifying.size(); ++q) {
    const CandidateOutcome& o = round.runs[qualifying[q]].outcome;
    if (std::abs(o.bic - best.outcome.bic) < options.ambiguity_margin) {
      tied.push_back(o.effect);
      by_bic = true;
    }
  }
  // A choice between the winner and another that the perturbed copies reverse
  // (QualifyingCandidates).
  bool by_stability = false;
  const std::size_t winner = qualifying.front();
  for (const auto& [a, b] : round.undecided) {
    if (a != winner && b != winner) continue;
    const std::string& name = round.runs[a == winner ? b : a].outcome.effect;
    if (std::find(tied.begin(), tied.end(), name) == tied.end()) tied.push_back(name);
    by_stability = true;
  }
  if (tied.size() <= 1) return {};
  // The best of equals is added (the model with none of them fits clearly worse than each: it
  // must not head the report) and the others are reported beside it, the headline's
  // intervals widened to cover their values (WidenForAmbiguity).
  std::vector<std::string> ambiguous_with(tied.begin() + 1, tied.end());
  std::vector<CandidateOutcome> models;
  for (const auto& name : tied) {
    for (std::size_t k : round.order) {
      if (round.runs[k].outcome.effect == name && round.runs[k].outcome.fitted) {
        models.push_back(round.runs[k].outcome);
        break;
      }
    }
  }
  result->ambiguous_models.push_back(models);
  // Listed by name: which of equals comes first carries no information.
  std::sort(tied.begin(), tied.end());
  result->ambiguous.push_back(tied);
  std::string names;
  for (const auto& n : tied) names += (names.empty() ? "" : " and ") + n;
  // The hint names what would separate these effects: the direction of motion only when one
  // of them is a friction (sign of w) and another a constant torque.
  bool friction = false, constant = false;
  for (const auto& n : tied) {
    const internal::EffectSearch* search = internal::FindEffectSearch(n);
    friction = friction || (search && search->pointer == internal::Pointer::kSignOfW);
    constant = constant || (search && search->pointer == internal::Pointer::kResidualMean);
  }
  const std::string why =
      by_bic ? " explain the residual equally well (BIC within " + G(options.ambiguity_margin) +
                   ")" + (by_stability ? "; " + round.undecided_reason : std::string())
             : " cannot be told apart: " + round.undecided_reason;
  result->ambiguity_reason =
      names + why +
      (!analysis.w_changes_sign && friction && constant
           ? "; w never changes sign on this data, so friction and a constant load look "
             "alike: record motion in both directions to tell them apart"
           : std::string(by_stability ? "; " : ": ") +
                 "an experiment that drives them differently (other speeds, amplitudes or "
                 "directions; blmd-design) would tell them apart");
  return ambiguous_with;
}

// The round's line in the report: the winner `winner` (an index into round.runs) added to the
// current model, with its evidence.
DiscoveryStep MakeStep(const Round& round, std::size_t winner, const FitResult& current_fit,
                       double current_bic, std::size_t current_free,
                       const ResidualAnalysis& analysis) {
  const CandidateRun& best = round.runs[winner];
  DiscoveryStep step;
  step.effect = best.outcome.effect;
  step.nrmse_before = std::sqrt(current_fit.evaluation.nrmse2);
  step.nrmse_after = best.outcome.nrmse;
  step.bic_before = current_bic;
  step.bic_after = best.outcome.bic;
  for (std::size_t k : round.order) step.candidates.push_back(round.runs[k].outcome);
  step.fixed_parameters = best.fixed;
  for (std::size_t k = current_free; k < best.fit.estimates.size(); ++k) {
    step.effect_parameters.push_back(best.fit.estimates[k]);
  }
  // The alternative added (cogging: its order), whose own evidence the line cites.
  const CandidatePlan& best_plan = round.plans[winner];
  int added_order = 0;
  std::string alternative_evidence;
  for (std::size_t a = 0; a < best_plan.fixed_alternatives.size(); ++a) {
    if (best_plan.fixed_alternatives[a] != best.fixed) continue;
    const auto periods = best.fixed.find("periods");
    if (periods != best.fixed.end()) added_order = static_cast<int>(std::lround(periods->second));
    if (a < best_plan.alternative_evidence.size())
      alternative_evidence = best_plan.alternative_evidence[a];
  }
  step.evidence = Evidence(step.effect, analysis, best.outcome, step.nrmse_before, added_order);
  if (!best_plan.evidence.empty()) step.evidence += "; " + best_plan.evidence;
  if (!alternative_evidence.empty()) step.evidence += "; " + alternative_evidence;
  return step;
}

// The final model as it runs free (its free parameters start at the winner's values), the
// model the report scores: fitted to convergence and checked for adequacy.
void FinishFinalModel(const FitProblem& problem, const FitProblem& current, FitResult current_fit,
                      const DiscoveryOptions& options, DiscoveryResult* result) {
  const FitProblem final_problem(current.config(), problem.traces(), problem.observe(),
                                 current.free());
  ProgressObserver* const progress = options.refit.progress;
  if (!result->added.empty() && !current_fit.summary.converged) {
    // The winner's refit stops after a few iterations (its free-running polish, 20): the
    // final model, which heads the report, is fitted to convergence from there (a
    // free-running cogging fit creeps along a narrow valley: 3 of 6 Coulomb + cogging cases
    // of the adequacy study stopped at 20 iterations, their answers right, the report saying
    // "not converged"). The user's Ceres options, else Ceres's own iteration limit, 100.
    if (progress) progress->BeginStage("final model: fitted to convergence", 0);
    FitResult converged = FindOptimizer("ceres").Minimize(final_problem, options.refit);
    if (converged.evaluation.ok && converged.evaluation.cost <= current_fit.evaluation.cost)
      current_fit = std::move(converged);
  }
  result->final_config = current.config();
  for (const auto& p : current.free()) result->final_free.push_back(p.name);
  result->final_free_parameters = current.free();
  result->final_fit = std::move(current_fit);
  if (options.check_adequacy) {
    if (progress) progress->BeginStage("adequacy check", 0);
    result->adequacy =
        CheckResidualStructure(final_problem, result->final_fit.values, options.adequacy);
    if (!result->added.empty()) {
      CheckEffectStability(final_problem, result->final_fit.values, result->added, options.refit,
                           options.adequacy, &result->adequacy);
    }
  }
}

// "; undecided: E (...)" when a candidate failed the stability check, else "".
std::string Undecided(const DiscoveryResult& result) {
  if (result.unstable.empty()) return "";
  std::string names;
  for (const auto& o : result.unstable) names += (names.empty() ? "" : ", ") + o.effect;
  return "; undecided: " + names +
         " (a change of the data far below their noise moves, or could move, its evidence, its "
         "cross-validated verdict or whether the record's parts can judge it)";
}

// The conclusion in words: what was added, "nothing missing", or "unexplained" when the
// adequacy check finds structure that no effect of the vocabulary took up.
std::string Conclusion(const DiscoveryResult& result, const DiscoveryOptions& options) {
  const std::string unexplained = result.adequacy.ok && !result.adequacy.flagged.empty()
                                      ? "unexplained: " + result.adequacy.StructureMessage() +
                                            ", and no effect of the vocabulary explains it"
                                      : std::string();
  std::string best;
  if (!result.last_round.empty() && result.last_round.front().fitted) {
    const CandidateOutcome& top = result.last_round.front();
    best = " (best candidate " + top.effect + ": BIC " + G(top.delta_bic, 4) +
           (top.reason.empty() ? std::string() : "; " + top.reason) + ")";
  }
  if (result.added.empty()) {
    return (!unexplained.empty()
                ? unexplained + best
                : "nothing missing: no effect lowers BIC by more than " + G(options.bic_margin) +
                      " with valid parameters, a material share of the residual and a lower "
                      "error on the data it was not fitted to" +
                      best) +
           Undecided(result);
  }
  std::string names;
  for (const auto& n : result.added) names += (names.empty() ? "" : ", ") + n;
  std::string conclusion = "added " + names;
  if (!result.ambiguous.empty())
    conclusion += " (the best of models that fit as well: " + result.ambiguity_reason + ")";
  if (!unexplained.empty()) conclusion += "; then " + unexplained;
  return conclusion + Undecided(result);
}

}  // namespace

DiscoveryResult Discover(const FitProblem& problem, const FitResult& initial,
                         const DiscoveryOptions& options) {
  DiscoveryResult result;
  const std::vector<std::string> candidates =
      CandidateEffects(options, std::string(problem.config().model->name()));
  // The current model: problem + fit.
  auto current_problem = std::make_unique<FitProblem>(problem);
  FitResult current_fit = initial;
  double current_bic = initial.evaluation.ok ? Bic(problem, initial.evaluation, problem.num_free())
                                             : std::numeric_limits<double>::infinity();
  result.bic_initial = current_bic;
  if (!initial.evaluation.ok) {
    result.conclusion = "the initial fit failed: nothing to examine";
    result.final_config = problem.config();
    result.final_fit = initial;
    return result;
  }
  // The measured columns' noise floor: the same for every round.
  result.noise_floor_nrmse = NoiseFloorNrmse(problem);
  // The stability check's copies of the data, the same for every round and every run.
  std::vector<std::vector<FitTrace>> perturbed;
  for (int k = 0; k < options.stability_checks; ++k) {
    perturbed.push_back(PerturbedTraces(problem.traces(), 0x5eed0000u + static_cast<unsigned>(k),
                                        options.stability_perturbation));
  }
  for (int number = 1; number <= options.max_effects; ++number) {
    const ResidualAnalysis analysis = AnalyseResidual(*current_problem, current_fit.values);
    Round round;
    round.number = number;
    if (!ScreenAndRefit(*current_problem, current_fit, current_bic, candidates, analysis,
                        result.noise_floor_nrmse, options, &round))
      break;
    CheckStability(problem, *current_problem, current_fit, perturbed, options, &round, &result);
    CrossValidateCandidates(problem, *current_problem, current_fit, perturbed, options, &round,
                            &result);
    const std::vector<std::size_t> qualifying = QualifyingCandidates(options, &round);
    if (qualifying.empty()) {
      for (std::size_t k : round.order) result.last_round.push_back(round.runs[k].outcome);
      break;
    }
    const std::size_t winner = qualifying.front();
    DiscoveryStep step =
        MakeStep(round, winner, current_fit, current_bic, current_problem->num_free(), analysis);
    step.ambiguous_with = RecordAmbiguity(round, qualifying, analysis, options, &result);
    result.steps.push_back(step);
    result.added.push_back(step.effect);
    // The winner becomes the current model, its fitted values its parameters.
    const CandidateRun& best = round.runs[winner];
    Config config = best.config;
    for (std::size_t k = 0; k < best.free.size(); ++k)
      config.parameters.Set(best.free[k].name, best.fit.values[k]);
    std::vector<FreeParameter> free = best.free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = best.fit.values[k];
    current_problem = std::make_unique<FitProblem>(
        MakeProblem(config, problem.traces(), problem.observe(), free));
    current_fit = best.fit;
    current_bic = best.outcome.bic;
  }
  FinishFinalModel(problem, *current_problem, std::move(current_fit), options, &result);
  result.conclusion = Conclusion(result, options);
  return result;
}

std::unique_ptr<FitProblem> FinalProblem(const FitProblem& problem, const DiscoveryResult& result) {
  if (result.added.empty()) return nullptr;
  // The bounds discovery fitted the effects in (their search boxes), the values as start.
  std::vector<FreeParameter> free = result.final_free_parameters;
  if (free.size() != result.final_fit.values.size()) return nullptr;
  for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = result.final_fit.values[k];
  return std::make_unique<FitProblem>(result.final_config, problem.traces(), problem.observe(),
                                      std::move(free));
}

}  // namespace blmd
