// Discovery's screening of one candidate (private to ident/discovery): the problem with the
// candidate added, a scan of its start points, short local searches and one Gauss-Newton step
// on every free parameter, scored by BIC against the current model (docs/discovery.md §3).
#pragma once

#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/progress.h"
#include "ident/discovery/effect_search.h"

namespace blmd::internal {

// One candidate of a round: its plan's outcome, the model with it, its fit.
struct CandidateRun {
  CandidateOutcome outcome;
  Config config;
  std::vector<FreeParameter> free;
  FitResult fit;
  std::map<std::string, double> fixed;
  std::vector<double> screen_values;  // after the scan and one Gauss-Newton step
  double screen_bic = std::numeric_limits<double>::infinity();  // delta BIC at screening
  bool refitted = false;
};

// The cross-validated choice between the best qualifying candidate and another one
// (docs/discovery.md §3d), from their out-of-sample NRMSE: whether the best gives way. To a
// simpler one (`simpler`) unless the best predicts the held-out data better by `margin` (a
// Stribeck curve must show its dip, not reshape a Coulomb friction); to one with as many
// parameters only when that one predicts them better by `margin`.
bool GivesWay(double first_nrmse, double other_nrmse, bool simpler, double margin);

// The stability check of a candidate's plain ΔBIC (docs/discovery.md §3d): whether its move
// from `on_data` to `on_copy` under a change of the data far below their noise could reverse
// the decision, which compares the score with -`margin`: the two lie on opposite sides of it
// and the move exceeds `tolerance`. A score that passes on the data and on the copy, however
// far it moves, decides the same way on both.
bool ScoreMoveReverses(double on_data, double on_copy, double margin, double tolerance);

// The first of the stability check's perturbed copies on which that choice between `first`
// and `other` (both cross-validated) is the reverse of the choice on the data, or none: a
// choice that a change of the data far below its noise reverses is no finding.
std::optional<std::size_t> FirstCopyReversingChoice(const CandidateOutcome& first,
                                                    const CandidateOutcome& other, bool simpler,
                                                    double margin);

// A decision made on the data, checked on the stability check's perturbed copies
// (docs/discovery.md §3d). `samples` is the statistic the decision compares with `threshold`,
// on the data first, then on each copy (NaN where it could not be computed). The decision
// holds when every finite sample lies on the data's side of the threshold and the 95 %
// Student-t prediction interval for one further copy, mean ± t(0.975, n-1)·s·sqrt(1 + 1/n)
// over the n finite samples (Hahn, Meeker & Escobar, Statistical Intervals, 2nd ed., 2017,
// ch. 4), does not reach it: copies that scatter as widely as the distance to the threshold
// say that a further one could reverse the decision, even when these few did not. One finite
// sample: nothing to check, it holds.
struct SideCheck {
  bool holds = true;
  double low = 0.0, high = 0.0;  // the prediction interval (the data's value when n = 1)
};
SideCheck CheckSide(const std::vector<double>& samples, double threshold);

// CheckSide for a ratio of two positive numbers (NRMSE over NRMSE), on a log scale where its
// scatter is symmetric and the interval stays positive; the interval is given as ratios.
SideCheck CheckRatio(const std::vector<double>& ratios, double threshold);

// The choice above on the data and every copy as the ratio CheckRatio tests: the ratio of
// the two out-of-sample NRMSE that GivesWay compares with 1 - margin (the best's over the
// simpler one's; the other's over the best's when it has as many parameters). NaN on a copy
// where either failed.
std::vector<double> ChoiceRatios(const CandidateOutcome& first, const CandidateOutcome& other,
                                 bool simpler);

// The problem over `traces` with `free`, fitted at the measured angle when the config has a
// position-dependent effect (the comment in screening.cc says why).
FitProblem MakeProblem(const Config& config, const std::vector<FitTrace>& traces,
                       const std::vector<std::string>& observe,
                       const std::vector<FreeParameter>& free);

// The screening grid (docs/discovery.md §3c). Screening only ranks the candidates and gives
// their refits a start, so it may simulate on a coarser fixed step than the config's where
// that changes the prediction far less than the noise does. A level is a step `factor` times
// the config's dt that leaves at least kMinGridStepsPerSample steps in the traces' shortest
// sample interval (an input change inside a step would be smeared), a divisor of its steps
// when the sampling is a whole number of steps (the samples stay on the grid), at most
// kMaxGridLevels of them, coarsest first; it is kept when the current
// model, and then each candidate at its probe point (ProbePoint), simulates on it with weighted
// residuals whose sum of squared differences from the config's step is at most
// kGridTolerance of the reference cost, the smaller of the model's cost and the noise's
// (NoiseFloorNrmse in the cost's units): a discretisation error of at most a tenth of the
// noise's RMS. No level with the events method (its step is not dt), the equation error (no
// simulation) or noise-free data.
inline constexpr double kGridTolerance = 1e-2;
// A friction reversal or a sticking shaft moves by whole steps, so the cost is a staircase in
// the parameters with steps that grow with dt: on one step per sample the local searches of
// the bundled record's hidden Coulomb friction stalled on it and screened it out; on 5 steps
// per sample (factor 10 of its 50) it screens as on the config's step
// (tests/unit/screening_grid_test.cc).
inline constexpr int kMinGridStepsPerSample = 4;
inline constexpr std::size_t kMaxGridLevels = 4;

class ScreeningGrid {
 public:
  // Level -1 is the config's own step; 0, 1, ... the coarser levels, coarsest first.
  int levels() const { return static_cast<int>(levels_.size()); }
  int Factor(int level) const { return level < 0 ? 1 : levels_[level].factor; }
  const FitProblem& Problem(int level, const FitProblem& fine) const {
    return level < 0 ? fine : *levels_[level].problem;
  }
  // The current model's BIC on the level (`fine_bic` on the config's step).
  double Bic(int level, double fine_bic) const { return level < 0 ? fine_bic : levels_[level].bic; }
  // The coarsest level (-1 without one).
  int Coarsest() const { return levels_.empty() ? -1 : 0; }
  // The coarsest level on which `plan`'s candidate at its probe point simulates within the
  // tolerance (-1: only the config's step). Its evaluations are reported to `progress`.
  int LevelFor(const FitProblem& fine, const std::vector<double>& values, const CandidatePlan& plan,
               ProgressObserver* progress) const;
  // The coarsest level on which `config` with `free` at `values` over `fine`'s traces
  // simulates within the tolerance (-1: only the config's step): where a refit model is
  // cross-validated.
  int LevelHolding(const FitProblem& fine, const Config& config,
                   const std::vector<FreeParameter>& free, const std::vector<double>& values) const;
  // The level's step, s (`dt` on the config's step).
  double Step(int level, double dt) const { return dt * Factor(level); }

 private:
  friend ScreeningGrid ChooseScreeningGrid(const FitProblem&, const std::vector<double>&, double);
  // The coarsest level on which `model` (on the config's step) at `values` simulates within
  // the tolerance, -1 on none; its evaluations reported to `progress` (may be null).
  int CoarsestHolding(const FitProblem& model, const std::vector<double>& values,
                      ProgressObserver* progress) const;
  struct Level {
    int factor = 1;
    std::shared_ptr<const FitProblem> problem;
    double bic = 0.0;
  };
  std::vector<Level> levels_;
  double reference_ = 0.0;
};

// True when `problem` simulates on a fixed step of its config's dt, the step a grid coarsens
// (not with the events method, nor with the equation error, which simulates nothing).
bool SimulatesOnFixedStep(const FitProblem& problem);

// The levels the current model at `values` allows (`floor_nrmse`: NoiseFloorNrmse).
ScreeningGrid ChooseScreeningGrid(const FitProblem& current, const std::vector<double>& values,
                                  double floor_nrmse);

// Screens `plan` against the current model `base` at `base_values` (whose BIC is
// `bic_before`): the scan over its start points with the other parameters held, short local
// searches from the best, then one Gauss-Newton step on all of them. Its evaluations are
// reported to `progress` (may be null).
CandidateRun ScreenCandidate(const FitProblem& base, const std::vector<double>& base_values,
                             const CandidatePlan& plan, double bic_before,
                             ProgressObserver* progress);

}  // namespace blmd::internal
