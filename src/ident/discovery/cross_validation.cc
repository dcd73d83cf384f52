// Discovery's block cross-validation (docs/discovery.md §3b-c): a candidate must predict the
// parts of the record it was not fitted to better than the current model does, on the data
// and on the stability check's perturbed copies; declared in round.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "blmd/format.h"
#include "ident/discovery/round.h"
#include "ident/residual/record_parts.h"

namespace blmd::internal {
namespace {

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

// Block cross-validation (docs/discovery.md §3b): `config` with `free` (initial values: the
// full fit's) fitted on each part of the record and scored on the other; the pooled NRMSE,
// sqrt of the mean of the two held-out costs. Each part's score is its own NRMSE (its
// columns' own variances). A model with a position-dependent effect is fitted and scored at
// the measured angle, as discovery fits it: a free-running prediction of a shaft in a cogging
// field over half a record hangs on where detents capture it (§6), not on the torque.
struct CrossValidation {
  bool ok = false;
  std::string reason;
  double nrmse = 0.0;
  std::string parts;  // how the record was cut (RecordParts::description)
};

CrossValidation BlockCrossValidate(const Config& config, const std::vector<FreeParameter>& free,
                                   const std::vector<FitTrace>& traces,
                                   const std::vector<std::string>& observe,
                                   const std::vector<double>& values,
                                   const OptimizerOptions& refit) {
  CrossValidation out;
  // The parts, the second starting from this model's own state at the cut.
  const RecordParts parts = SplitRecord(FitProblem(config, traces, observe, free), values);
  out.parts = parts.description;
  if (!parts.ok) {
    out.reason = parts.reason;
    return out;
  }
  double sum = 0.0;
  for (int fold = 0; fold < 2; ++fold) {
    const std::vector<FitTrace>& fit_on = fold == 0 ? parts.first : parts.second;
    const std::vector<FitTrace>& score_on = fold == 0 ? parts.second : parts.first;
    const FitProblem fit_problem = MakeProblem(config, fit_on, observe, free);
    OptimizerOptions options = refit;
    options.method_options = nlohmann::json::object();
    options.method_options["max_iterations"] = 20;
    const FitResult fit = FindOptimizer("ceres").Minimize(fit_problem, options);
    if (!fit.evaluation.ok) {
      out.reason = "a fold's fit failed: " + fit.evaluation.reason;
      return out;
    }
    const FitProblem score_problem = MakeProblem(config, score_on, observe, free);
    const Evaluation score = score_problem.Evaluate(fit.values);
    if (!score.ok) {
      out.reason = "a fold's prediction failed: " + score.reason;
      return out;
    }
    sum += score.nrmse2;
  }
  out.ok = true;
  out.nrmse = std::sqrt(0.5 * sum);
  return out;
}

// The free parameters of `problem` starting at `values`.
std::vector<FreeParameter> StartingAt(const std::vector<FreeParameter>& free,
                                      const std::vector<double>& values) {
  std::vector<FreeParameter> out = free;
  for (std::size_t k = 0; k < out.size() && k < values.size(); ++k)
    out[k].initial = std::clamp(values[k], out[k].lower, out[k].upper);
  return out;
}

// The current model's cross-validation on one level of the screening grid (`config` has its
// step), on the data and on each perturbed copy, and whether the record's parts can judge a
// candidate there (CrossValidateCandidates).
struct CurrentOnParts {
  CrossValidation on_data;
  std::vector<CrossValidation> on_copies;
  // Whether the parts can judge a candidate (below), and whether that holds on the copies.
  bool usable = true;
  bool usable_holds = true;
};

CurrentOnParts CrossValidateCurrent(const FitProblem& problem, const FitProblem& current,
                                    const FitResult& fit,
                                    const std::vector<std::vector<FitTrace>>& perturbed,
                                    const Config& config, const DiscoveryOptions& options,
                                    const Round& round, DiscoveryResult* result) {
  CurrentOnParts level;
  level.on_data =
      BlockCrossValidate(config, StartingAt(current.free(), fit.values), problem.traces(),
                         problem.observe(), fit.values, options.refit);
  if (result->cross_validation_parts.empty()) {
    result->cross_validation_parts = level.on_data.parts;
    // Parts that cannot be fitted (a half at rest) judge nothing: the evidence alone decides.
    if (!level.on_data.ok && !level.on_data.reason.empty()) {
      result->cross_validation_parts += (result->cross_validation_parts.empty() ? "" : " ") +
                                        std::string("(not used: ") + level.on_data.reason + ")";
    }
  }
  // The copies' fits also start a little off the values (where the previous fits stopped
  // is known only to their tolerance): a verdict that hinges on that is no finding either.
  std::vector<double> usable_ratio = {level.on_data.nrmse / round.base.nrmse};
  for (std::size_t c = 0; c < perturbed.size() && level.on_data.ok; ++c) {
    const std::vector<double> start =
        Jittered(fit.values, current.free(), 0x5eed1000u + c, options.stability_start);
    level.on_copies.push_back(BlockCrossValidate(config, StartingAt(current.free(), start),
                                                 perturbed[c], problem.observe(), start,
                                                 options.refit));
    usable_ratio.push_back(level.on_copies.back().ok
                               ? level.on_copies.back().nrmse / round.base.nrmse
                               : std::numeric_limits<double>::quiet_NaN());
  }
  // Parts that do not predict each other even with the current model (a cross-validated
  // NRMSE over twice the fitted one) cannot judge a candidate: the evidence alone decides,
  // and the report says why (cross_validation_parts). Whether they can is itself checked
  // on the copies and near the limit: where it is too close to call, a candidate is added only
  // when it generalises on the data and on every copy, so that either way it would be added.
  level.usable = level.on_data.nrmse <= 2.0 * round.base.nrmse;
  const SideCheck usable = CheckRatio(usable_ratio, 2.0);
  const double to_limit = level.on_data.nrmse / (2.0 * round.base.nrmse) - 1.0;
  // Near the limit is too close to call only where the parts' fits are chaotic: a copy's
  // NRMSE more than 1e-6 (a thousand times the change of the data) from the data's.
  bool chaotic = false;
  for (double r : usable_ratio) {
    if (std::isfinite(r) && !(std::abs(r / usable_ratio.front() - 1.0) <= 1e-6)) chaotic = true;
  }
  const bool near = chaotic && std::abs(to_limit) <= options.usable_band;
  level.usable_holds = usable.holds && !near;
  if (level.on_data.ok && !level.usable_holds) {
    const std::string could = "a change of the data of " + G(options.stability_perturbation, 2) +
                              " of their values could give " + G(usable.low * round.base.nrmse) +
                              " to " + G(usable.high * round.base.nrmse);
    result->cross_validation_parts +=
        " (in round " + std::to_string(round.number) +
        ", whether the parts can judge a candidate is too close to call: they predict "
        "each other with NRMSE " +
        G(level.on_data.nrmse) + " against " + G(round.base.nrmse) + " fitted, " +
        (near ? "within " + G(100.0 * options.usable_band) +
                    " % of the limit of twice the fitted, and " + could
              : "and " + could + ", across the limit of twice the fitted") +
        "; a candidate is added only where it generalises on the data and on every copy)";
  } else if (level.on_data.ok && !level.usable) {
    result->cross_validation_parts += " (not used in round " + std::to_string(round.number) +
                                      ": the parts predict each other with NRMSE " +
                                      G(level.on_data.nrmse) + " against " + G(round.base.nrmse) +
                                      " fitted)";
  }
  return level;
}

}  // namespace

// Block cross-validation of every candidate that passes the evidence, best first: each must
// predict the record's parts it was not fitted to better than the current model does.
void CrossValidateCandidates(const FitProblem& problem, const FitProblem& current,
                             const FitResult& fit,
                             const std::vector<std::vector<FitTrace>>& perturbed,
                             const DiscoveryOptions& options, Round* round,
                             DiscoveryResult* result) {
  if (!options.cross_validate || (options.held_out && !options.held_out->empty())) return;
  ProgressObserver* const progress = options.refit.progress;
  // Each candidate is cross-validated on the coarsest level of the screening grid on which its
  // refit model simulates within the grid's tolerance (docs/discovery.md §3c), and compared
  // with the current model's cross-validation on the same level, computed when first needed,
  // with those on each perturbed copy.
  const double dt = current.config().simulation.dt;
  std::map<int, CurrentOnParts> levels;
  auto OnStep = [](Config config, double step) {
    config.simulation.dt = step;
    return config;
  };
  for (std::size_t k : round->order) {
    CandidateRun& run = round->runs[k];
    CandidateOutcome& o = run.outcome;
    if (!PassesEvidence(o, options)) continue;
    const int level_index = round->grid.LevelHolding(problem, run.config, run.free, run.fit.values);
    const double step = round->grid.Step(level_index, dt);
    auto found = levels.find(level_index);
    if (found == levels.end()) {
      found = levels
                  .emplace(level_index, CrossValidateCurrent(problem, current, fit, perturbed,
                                                             OnStep(current.config(), step),
                                                             options, *round, result))
                  .first;
    }
    const CurrentOnParts& level = found->second;
    const CrossValidation& base_cv = level.on_data;
    if (!base_cv.ok) break;  // nothing to compare with: the evidence alone decides
    // Parts that do not predict each other with the current model cannot judge a candidate:
    // the evidence alone decides, except for a deterministic one (§3a), which is judged by
    // whether it makes the parts predict each other, below.
    const bool parts_unusable = !level.usable && level.usable_holds;
    if (parts_unusable && !o.deterministic) continue;
    if (progress) {
      progress->BeginStage(
          "discovery round " + std::to_string(round->number) + ": cross-validating " + o.effect, 0);
    }
    const Config config = OnStep(run.config, step);
    const CrossValidation cv =
        BlockCrossValidate(config, StartingAt(run.free, run.fit.values), problem.traces(),
                           problem.observe(), run.fit.values, options.refit);
    if (!cv.ok) {
      // The candidate keeps its evidence-only verdict, unless that hinges on whether the
      // parts could judge it: then nothing decides it.
      if (!level.usable_holds) {
        o.stable = false;
        o.reason =
            "unstable: whether the record's parts can judge it is too close to call, "
            "and its cross-validation failed, so the record cannot decide it (not added)";
        RecordUnstable(o, result);
      }
      continue;
    }
    o.cross_validated = true;
    if (SimulatesOnFixedStep(current)) o.cross_validation_step = step;
    o.cv_before = base_cv.nrmse;
    o.cv_after = cv.nrmse;
    o.generalises = cv.nrmse < (1.0 - options.held_out_margin) * base_cv.nrmse;
    if (parts_unusable && o.generalises && !(cv.nrmse <= 2.0 * o.nrmse)) {
      o.generalises = false;
      o.reason =
          "tried, not needed: the record's parts do not predict each other with it either "
          "(cross-validated NRMSE " +
          G(o.cv_after) + " against " + G(o.nrmse) +
          " fitted), so they cannot confirm a residual the whitened evidence refuses";
    } else if (!o.generalises) {
      o.reason = "tried, not needed: does not generalise (cross-validated NRMSE " + G(o.cv_before) +
                 " -> " + G(o.cv_after) + ", needs a fall of more than " +
                 G(100.0 * options.held_out_margin) + " %)";
    }
    // The verdict again on each perturbed copy (docs/discovery.md §3d): the half-record fits
    // of a model that is chaotic on this record land in other minima under a change of the
    // data far below their noise, and a verdict that flips, or that the copies' scatter says
    // a further copy could flip, is not a finding.
    o.cv_perturbed.assign(perturbed.size(), std::numeric_limits<double>::quiet_NaN());
    std::vector<double> ratios = {cv.nrmse / base_cv.nrmse};
    std::optional<std::size_t> reversing;
    for (std::size_t c = 0; c < level.on_copies.size(); ++c) {
      const CrossValidation& copy_base = level.on_copies[c];
      const std::vector<double> start =
          Jittered(run.fit.values, run.free, 0x5eed2000u + c, options.stability_start);
      const CrossValidation copy =
          BlockCrossValidate(config, StartingAt(run.free, start), perturbed[c], problem.observe(),
                             start, options.refit);
      if (copy.ok) o.cv_perturbed[c] = copy.nrmse;
      const bool both = copy_base.ok && copy.ok;
      ratios.push_back(both ? copy.nrmse / copy_base.nrmse
                            : std::numeric_limits<double>::quiet_NaN());
      if (!both) continue;
      const bool generalises = copy.nrmse < (1.0 - options.held_out_margin) * copy_base.nrmse;
      if (generalises == o.generalises) continue;
      reversing = c;  // unstable: the other copies cannot change that
      break;
    }
    const SideCheck verdict = CheckRatio(ratios, 1.0 - options.held_out_margin);
    const std::string by = G(options.stability_perturbation, 2) + " of their values";
    const std::string change = "a change of the data of " + by;
    const std::string on_data =
        "cross-validated NRMSE " + G(o.cv_before) + " -> " + G(o.cv_after) + " on the data";
    if (reversing) {
      const std::size_t c = *reversing;
      o.stable = false;
      o.reason = "unstable: " + change + " reverses its cross-validated verdict (" + on_data +
                 ", " + G(level.on_copies[c].nrmse) + " -> " + G(o.cv_perturbed[c]) +
                 " on a copy), so the record cannot decide it (not added)";
    } else if (!verdict.holds) {
      o.stable = false;
      o.reason = "unstable: the copies of the data changed by " + by +
                 " scatter so that a further one could reverse its cross-validated verdict (" +
                 on_data + ": a ratio of " + G(ratios.front()) + ", a further copy's within " +
                 G(verdict.low) + " to " + G(verdict.high) + " against " +
                 G(1.0 - options.held_out_margin) + "), so the record cannot decide it (not added)";
    } else if (!level.usable_holds &&
               (!o.generalises || !std::all_of(ratios.begin(), ratios.end(),
                                               [](double r) { return std::isfinite(r); }))) {
      // Added either way only when it generalises on the data and on every copy.
      o.stable = false;
      o.reason =
          "unstable: whether the record's parts can judge it is too close to call, and "
          "where they can, it " +
          std::string(o.generalises ? "could not be cross-validated on every copy"
                                    : "does not generalise") +
          " (" + on_data + "), so the record cannot decide it (not added)";
    }
    if (!o.stable) RecordUnstable(o, result);
  }
}

}  // namespace blmd::internal
