// Discovery's rounds (private to ident/discovery): what a round of the search holds, and the
// steps that judge its candidates beyond their evidence, each in its own file: the block
// cross-validation (cross_validation.cc, docs/discovery.md §3b-c) and the stability check on
// perturbed copies of the data (stability.cc, §3d). discovery.cc runs the rounds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "ident/discovery/screening.h"
#include "parallel.h"

namespace blmd::internal {

// What every candidate of a round is compared with, computed once per round: the current
// model's residuals on the fit traces (for the prewhitened evidence) or its error on the
// held-out traces (for the held-out rule).
struct RoundBase {
  std::vector<double> residuals;  // empty when its evaluation failed
  Evaluation held_out;            // ok only with held-out traces that simulate
  double nrmse = 0.0;             // the current model's
  double floor_nrmse = 0.0;       // the noise floor (NoiseFloorNrmse)
};

// One round of the search: the candidates planned, screened and refit, and their order.
struct Round {
  int number = 1;  // from 1, for the progress stages and the report's words
  std::vector<CandidatePlan> plans;
  std::vector<CandidateRun> runs;  // one per plan
  std::vector<std::size_t> order;  // indices into runs, best first
  RoundBase base;                  // what every candidate is compared with
  ScreeningGrid grid;              // the screening grid's levels (screening.h)
  std::vector<int> levels;         // per run: the level it was planned and screened on
  // Pairs of qualifying candidates (indices into runs) whose choice by cross-validation a
  // perturbed copy of the data reverses, and the words for the last (QualifyingCandidates).
  std::vector<std::pair<std::size_t, std::size_t>> undecided;
  std::string undecided_reason;
};

// `work` on each of `items`, on `threads` threads.
inline void ForEachItem(const std::vector<std::size_t>& items, int threads,
                        const std::function<void(std::size_t)>& work) {
  ParallelFor(items.size(), threads, [&](std::size_t k) { work(items[k]); });
}

// The stopping rule (docs/discovery.md §3b): the evidence, physically valid, material, and
// generalising to the part of the record it was not fitted to; and a decision that holds when
// the data change far below their noise (§3d).
inline bool PassesEvidence(const CandidateOutcome& o, const DiscoveryOptions& options) {
  const bool evidence = o.delta_bic < -options.bic_margin ||
                        (o.deterministic && o.delta_bic_white < -options.bic_margin);
  return o.fitted && o.valid && o.held_out_better && evidence && o.material && o.stable;
}

// Block cross-validation (cross_validation.cc): every candidate that passes the evidence, best
// first, must predict the record's parts it was not fitted to better than the current model
// does, on the data and on each perturbed copy; one that does not is marked (its reason), one
// whose verdict the copies could reverse is marked unstable and listed in result->unstable.
void CrossValidateCandidates(const FitProblem& problem, const FitProblem& current,
                             const FitResult& fit,
                             const std::vector<std::vector<FitTrace>>& perturbed,
                             const DiscoveryOptions& options, Round* round,
                             DiscoveryResult* result);

// The stability check's copies (stability.cc): the data with every measured value, the
// recorded input and the initial state scaled by 1 + relative·z, z standard normal from `seed`.
std::vector<FitTrace> PerturbedTraces(const std::vector<FitTrace>& traces, std::uint64_t seed,
                                      double relative);

// `values` each scaled by 1 + relative·z (z standard normal from `seed`), kept in their bounds.
std::vector<double> Jittered(std::vector<double> values, const std::vector<FreeParameter>& free,
                             std::uint64_t seed, double relative);

// Records `o` in result->unstable, replacing an earlier round's outcome of the same effect.
void RecordUnstable(const CandidateOutcome& o, DiscoveryResult* result);

// The stability check (DiscoveryOptions::stability_checks, docs/discovery.md §3d): every
// candidate with a screened or refit point is scored again on the perturbed copies; one whose
// plain ΔBIC moves across the evidence threshold is marked unstable (never added), its reason
// saying by how much, and listed in result->unstable.
void CheckStability(const FitProblem& problem, const FitProblem& current, const FitResult& fit,
                    const std::vector<std::vector<FitTrace>>& perturbed,
                    const DiscoveryOptions& options, Round* round, DiscoveryResult* result);

}  // namespace blmd::internal
