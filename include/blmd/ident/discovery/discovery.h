// Closing the loop (docs/discovery.md): fit, examine the residual, find the effect the
// model lacks, add it, refit, repeat until nothing significant is left.
//
// Each round, every applicable effect of the vocabulary not yet in the model is a
// candidate. A candidate is screened: a small deterministic scan of its parameters
// (periods of cogging from the torque balance along the measured motion for rigid_load, from
// the residual's angle spectrum otherwise; i0 from the current residual's mean) with the
// others held, then one damped Gauss-Newton step on all free parameters (for cogging, when
// that does not lower BIC on the free-running model, a short free-running search from it).
// The `refits` best by screening BIC are refit in full (Ceres, all parameters). Each is
// scored by the
// Bayesian information criterion with each observed column's own noise level,
//   BIC = sum_c N_c ln(SSE_c / N_c) + k ln N,
// and qualifies when it lowers BIC by more than `bic_margin` (10: "very strong" evidence)
// and its parameters are physically valid (inside their constraints, e.g. |dB| < B for
// asymmetric_viscous, off their search bounds, and away from zero by more than two standard
// deviations). The best qualifying
// candidate is added; if another qualifying candidate is within `ambiguity_margin` (2) of
// it, the data cannot tell them apart and the round reports them as ambiguous and adds
// nothing.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/residual/adequacy.h"
#include "blmd/ident/residual/diagnostics.h"

namespace blmd {

struct DiscoveryOptions {
  double bic_margin = 10.0;             // BIC must fall by more than this to add an effect
  double ambiguity_margin = 2.0;        // candidates closer than this to the best are ambiguous
  int max_effects = 3;                  // rounds
  int refits = 3;                       // candidates refit in full per round (best by screening)
  std::vector<std::string> candidates;  // empty: every applicable effect
  // Options of the Ceres refits (threads, budgets). Its `progress`, when set, also gets
  // discovery's stages (per round: "discovery round 1: screening", one step per candidate,
  // then "discovery round 1: refits", one per refit) and the screening's evaluations.
  OptimizerOptions refit;
  // Held-out traces (--validate), or null. With them, a candidate must qualify by the plain
  // BIC on the fit traces AND lower the held-out NRMSE by more than `held_out_margin`
  // (relative); without them, by the BIC on prewhitened residuals (evidence.h).
  const std::vector<FitTrace>* held_out = nullptr;
  // false: every sample counts as independent (the plain BIC of versions before 0.2; kept
  // for comparison in the studies of docs/discovery.md).
  bool prewhiten = true;
  double held_out_margin = 0.01;
  // The stopping rule (docs/discovery.md §3b). Materiality: a candidate must explain at
  // least this share of what the current model leaves above the noise floor,
  //   (NRMSE_before^2 - NRMSE_after^2) / (NRMSE_before^2 - floor^2),
  // the floor from the measured columns' second differences (NoiseFloorNrmse, fit/noise_floor.h).
  double min_explained_share = 0.10;
  // A deterministic residual that the prewhitened evidence's noise model absorbs (a
  // square-wave-like friction residual is what an AR(2) model predicts best): a candidate
  // whose prewhitened ΔBIC does not pass but whose plain ΔBIC does, that explains at least
  // this share of the residual above the noise floor, and that is cross-validated on the
  // record's parts and generalises there, passes the evidence (docs/discovery.md §3a,
  // "Deterministic residuals"). Coloured noise is not explained at this share by one
  // effect, and does not generalise from one half of a record to the other.
  double deterministic_share = 0.25;
  // Generalisation without held-out traces: the record is cut in two (record_parts.h), the
  // model with and without the candidate fitted on each part and scored on the other; the
  // pooled cross-validated NRMSE must fall by more than `held_out_margin`. false: skip it
  // (the evidence alone decides, as before version 0.3).
  bool cross_validate = true;
  // The model-adequacy check on the final model (adequacy.h); false: skip it.
  bool check_adequacy = true;
  AdequacyOptions adequacy;
  // Stability of each decision (docs/discovery.md §3d): every screened or refit candidate's
  // plain ΔBIC is scored again, at the same parameter values, on `stability_checks` copies of
  // the data whose every measured value (and recorded input and initial state) is scaled by
  // 1 + `stability_perturbation`·z, z standard normal (seeded: the same copies on every run).
  // A candidate whose ΔBIC, on the data as given or on a copy, passes the evidence threshold
  // (below -bic_margin) and moves by more than `stability_relative` of itself (at least
  // `stability_tolerance`) on a copy hinges on the data's last bits (a simulated shaft
  // settling in one detent or the next): it is never added and the report says so.
  // 0 checks: off.
  int stability_checks = 2;
  double stability_perturbation = 1e-9;
  double stability_tolerance = 1.0;
  double stability_relative = 0.1;
  // The cross-validation's verdict is checked the same way, on the copies, with its fits
  // started `stability_start` (relative) off the values, which earlier fits reach only to
  // their tolerance: a verdict that flips is not a finding either.
  //
  // Nor is one whose copies scatter so widely that the 95 % prediction interval for a further
  // copy reaches its threshold; the same holds for the choice between two candidates and for
  // whether the record's parts can judge a candidate at all (docs/discovery.md §3d).
  double stability_start = 1e-6;
  // Whether the record's parts can judge a candidate (their cross-validated NRMSE within
  // twice the fitted one) is treated as too close to call within `usable_band` (relative) of
  // that limit when the parts' fits are chaotic (a copy's NRMSE more than 1e-6 from the
  // data's), whatever the copies' interval says: there the parts' NRMSE moves by about 0.5 %
  // under a change of 1e-9 of the data or another build's rounding, more than two copies
  // reliably show (docs/discovery.md §3d).
  double usable_band = 0.05;
};

struct CandidateOutcome {
  std::string effect;
  bool fitted = false;
  bool valid = false;
  std::string reason;  // why not valid / not fitted
  double bic = 0.0;
  double delta_bic = 0.0;        // vs the model before this round (negative: better), from the
                                 // prewhitened residuals once refit (evidence.h)
  double delta_bic_white = 0.0;  // the same with every sample independent (plain BIC)
  // Per observed column, the noise model the evidence used: AR order and the ratio of the
  // innovation to the residual variance (1: white).
  std::map<std::string, std::pair<int, double>> noise_model;
  // With held-out traces: their NRMSE without and with the effect (parameters from the fit
  // traces), and whether it fell by more than the margin.
  bool has_held_out = false;
  double held_out_before = 0.0, held_out_after = 0.0;
  bool held_out_better = true;
  std::string evidence_rule;  // "prewhitened_bic" or "held_out" (docs/discovery.md)
  // The prewhitened ΔBIC does not pass but the plain one does, and the candidate explains at
  // least DiscoveryOptions::deterministic_share of the residual above the noise floor: it
  // passes the evidence when its cross-validation confirms it (docs/discovery.md §3a).
  bool deterministic = false;
  double nrmse = 0.0;
  // The stopping rule: the share of what was left above the noise floor that the candidate
  // explains (negative: not computed), and whether it clears DiscoveryOptions'
  // min_explained_share.
  double explained_share = -1.0;
  bool material = true;
  // Block cross-validation (when computed): the pooled NRMSE on the part not fitted, of
  // the current model and of the model with the candidate, and whether it fell by more
  // than the margin.
  bool cross_validated = false;
  double cv_before = 0.0, cv_after = 0.0;
  bool generalises = true;
  // Its cross-validated NRMSE on each perturbed copy of the stability check (NaN where that
  // failed): the choice between two candidates that their cross-validation makes is checked
  // on these too (docs/discovery.md §3d).
  std::vector<double> cv_perturbed;
  std::map<std::string, double> parameters;  // the effect's fitted parameters
  // Every free parameter of the model with this effect (J, B, ... and the effect's), as
  // refit: what an ambiguous round reports for each competing model.
  std::map<std::string, double> model_parameters;
  // The stability check (DiscoveryOptions::stability_checks): the plain ΔBIC, free running,
  // at the values judged (refit, else screened) on the data as given and on each perturbed
  // copy; `stable` false when one moved by more than the tolerance (or failed to simulate),
  // or when the cross-validated verdict, its scatter on the copies, or whether the record's
  // parts can judge it does not hold (docs/discovery.md §3d; the reason says which).
  bool stability_checked = false;
  bool stable = true;
  double stability_delta_bic = 0.0;
  std::vector<double> stability_perturbed;
  // The fixed steps (s) it was screened and cross-validated on: the config's, or the coarser
  // screening grid's where that simulates it as faithfully (docs/discovery.md §3c); 0 where
  // the model has no fixed step (the events method, the equation error) or it was not done.
  double screening_step = 0.0;
  double cross_validation_step = 0.0;
};

struct DiscoveryStep {
  std::string effect;
  std::vector<ParameterEstimate> effect_parameters;  // with intervals
  std::map<std::string, double> fixed_parameters;    // e.g. cogging periods
  double nrmse_before = 0.0, nrmse_after = 0.0;
  double bic_before = 0.0, bic_after = 0.0;
  std::vector<CandidateOutcome> candidates;  // every candidate of the round, best first
  std::string evidence;                      // one line: why this effect
  // Effects that explained the residual as well (BIC within the ambiguity margin): this one
  // was added as the best of them, so that the model is not left clearly worse than any.
  std::vector<std::string> ambiguous_with;
};

struct DiscoveryResult {
  std::vector<std::string> added;
  std::vector<DiscoveryStep> steps;
  // Rounds that stopped because the best candidates could not be told apart.
  std::vector<std::vector<std::string>> ambiguous;
  // Each ambiguous round's competing models as refit (in the order of `ambiguous`).
  std::vector<std::vector<CandidateOutcome>> ambiguous_models;
  std::string ambiguity_reason;
  // Candidates whose decision did not hold under the stability check, the latest round's
  // outcome of each (never added).
  std::vector<CandidateOutcome> unstable;
  std::vector<CandidateOutcome> last_round;  // the round that added nothing, best first
  std::string conclusion;                    // one line for people
  Config final_config;                       // with the added effects at their fitted values
  std::vector<std::string> final_free;
  std::vector<FreeParameter> final_free_parameters;  // with the bounds discovery fitted them in
  FitResult final_fit;
  double bic_initial = 0.0;
  // The noise floor of the measured columns in NRMSE units (sqrt of the mean over columns
  // of sigma_c^2 / Var_c; NoiseFloor), what the stopping rule measures shares against.
  double noise_floor_nrmse = 0.0;
  std::string cross_validation_parts;  // how the record was cut for the cross-validation
  // The final model's adequacy: what its residual still depends on, and whether the added
  // effects' parameters hold still across the record (adequacy.h).
  AdequacyReport adequacy;
};

// BIC of `evaluation` for `k` free parameters (see above).
double Bic(const FitProblem& problem, const Evaluation& evaluation, std::size_t k);

// Runs discovery from an initial fit of `problem` (whose result is `initial`).
DiscoveryResult Discover(const FitProblem& problem, const FitResult& initial,
                         const DiscoveryOptions& options);

// The model after discovery as a problem over the traces of `problem` (its observed columns,
// the final free parameters with the final config's bounds); null when nothing was added.
std::unique_ptr<FitProblem> FinalProblem(const FitProblem& problem, const DiscoveryResult& result);

}  // namespace blmd
