// Is the model adequate? What the residual of a fitted model still depends on, and whether
// the effects it carries hold still across the record (docs/discovery.md §7).
//
// Discovery names effects from a vocabulary. When the machine does something the vocabulary
// has no word for (a disturbance at a fixed frequency, a load that grows in time, a dead
// zone), the nearest names can lower the error a little each and the answer looks clean.
// This check is run on the final model whatever was added, and says what is left:
//
// Residual structure. For every observed column c, the residual r = measured - simulated
// (every trace, pooled) is regressed on one basis per state at a time (the states as the
// model simulates them: a measured state carries the noise under test):
//   theta            theta (centred, scaled), sin theta, cos theta  (springs, gravity)
//   theta (periodic) sin m theta, cos m theta for the best m in 2..max_order (cogging-like)
//   w                indicators of `bins` quantile bins of w          (speed-shaped losses)
//   sign(w)          the sign of w                                   (friction)
//   u                indicators of the quantile bins of u            (the input's level)
//   t                Legendre polynomials P1..P_degree of t, per trace (drift, a growing load)
//   mean             the residual's own mean per trace against zero (an offset, a constant
//                    torque; every other basis keeps the means in its null model)
//   t (periodic)     sin 2 pi f t, cos 2 pi f t per trace at the periodogram's peak f
//                    (named a harmonic of the input when it is one: a dynamic misfit
//                    repeats with the input, a disturbance need not)
//   u (past)         the whitened input at the L previous samples (input_residual.h: the
//                    input-residual test, dynamics the model lacks; output error only)
// each with an intercept (per trace). The test is a feasible generalised least-squares F
// test: an AR(p <= 2) noise model is fitted to the regression's own residual (Yule-Walker,
// evidence.h FitAutoregression), the response and every regressor are filtered with it
// (per trace, Cochrane-Orcutt; Greene, Econometric Analysis, 7th ed., §20.9), and
//   F = ((SSE_0 - SSE_1) / q) / (SSE_1 / (n - k))
// is referred to F(q, n - k) (Boost.Math). Searched bases (the best m, the best f) carry a
// Bonferroni factor for the number of alternatives searched, and every p-value one for the
// number of tests (bases x columns): the check holds its family-wise false-alarm rate at
// `family_level`. A significant basis is flagged only when it is also material: its OLS fit
// explains at least `min_share` of the residual's variance (a 2 % ripple on a white
// residual of 100 000 samples is significant but not worth a warning).
//
// Effect stability. Each trace is cut into two contiguous halves (with >= 2 traces: the
// traces themselves) and the final model is refit on each part alone (Ceres, from the final
// values). An effect parameter whose two estimates differ by more than z_{family}
// sqrt(s_1^2 + s_2^2) (their standard errors; z for a two-sided family-wise `family_level`
// over every compared parameter), and by more than `min_relative_change` of its value, is
// not a constant of the machine: the effect is flagged unstable (a load that grows, a
// friction that warms up, an effect that stands in for something else).
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/noise_floor.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"

namespace blmd {

struct AdequacyOptions {
  double family_level = 1e-3;         // family-wise false-alarm level of each check
  double min_share = 0.10;            // a flagged structure explains at least this of the variance
  int bins = 10;                      // quantile bins of w and of u
  int legendre_degree = 4;            // P1..P4 in t per trace
  int max_order = 64;                 // theta (periodic): orders 2..max_order
  double max_frequency_hz = 0;        // t (periodic): up to this (0: the Nyquist frequency)
  int ar_max_order = 2;               // the FGLS noise model
  double min_relative_change = 0.10;  // effect stability: the smallest change that matters
  // mean: also test each trace's residual mean against zero (FglsMeanTest): an offset or a
  // constant torque the model lacks, which every other basis takes into its null model.
  bool test_mean = true;
  // u (past): the lags L of the input-residual test (input_residual.h); 0: not made. Made on
  // output-error fits only: the equation error's residual is made from the input itself.
  int input_lags = 25;
};

// One basis against one observed column.
struct StructureTest {
  // "theta", "theta (periodic)", "w", "sign(w)", "u", "t", "t (periodic)", "mean", "u (past)"
  std::string state;
  std::string column;    // the observed column whose residual is tested
  int regressors = 0;    // q, the basis's columns (without the intercepts)
  double f = 0.0;        // the F statistic
  double p_value = 1.0;  // with the Bonferroni factors (searched alternatives, tests)
  double share = 0.0;    // fraction of the residual's variance the basis explains (OLS R^2)
  int ar_order = 0;      // of the FGLS noise model
  double frequency_hz =
      0.0;  // t (periodic): the frequency tested; u (past): the residual's largest response to u
  int lags = 0;  // u (past): the lags tested, 1..lags samples
  // u (past) on w or theta: the delay (s) by which the measured column lags the simulated one
  // when a delay explains at least half of what the input's past does (a sensor, filter or
  // logger lag: residual ~ -lag d(simulated)/dt); 0 when it does not.
  double lag_s = 0.0;
  int input_harmonic = 0;    // t (periodic): k when it is the input's k-th harmonic, else 0
  int order = 0;             // theta (periodic): the order tested, periods per revolution
  bool significant = false;  // p_value < family_level
  bool flagged = false;      // significant and share >= min_share
  // Flagged tests: the residual's mean in bins of the state (what the HTML plots), x the bin
  // centres in the state's unit (periodic states: the phase within one period, 0..1); for
  // u (past) the whitened residual's correlation with the whitened input at each lag (x in
  // ms), and `band95` the 95 % band of a correlation under no dependence.
  std::vector<double> bin_x, bin_mean;
  std::vector<int> bin_count;
  std::string x_label, x_unit;
  double band95 = 0.0;
  // "t (periodic, 4.5 Hz)", "theta (periodic, 7/rev)", "w", "u (past, largest at 63 Hz)"
  std::string Describe() const;
};

struct EffectStability {
  std::string effect;
  std::string parameter;
  double first = 0.0, second = 0.0;          // the two parts' estimates
  double first_std = 0.0, second_std = 0.0;  // their standard errors (0: none)
  double z = 0.0;                            // |first - second| / sqrt(s1^2 + s2^2)
  double limit = 0.0;                        // the family-wise z it is compared with
  bool unstable = false;
  // A part's estimate lies within two of its standard errors of its search bound (or on it):
  // no normal interval holds there, and the pair is not compared (never unstable).
  bool near_bound = false;
};

struct AdequacyReport {
  bool ok = false;
  std::string reason;  // why not ok (the model could not be simulated)
  double family_level = 1e-3, min_share = 0.1;
  std::vector<StructureTest> tests;  // every test, column by column, basis by basis
  // The flagged tests, largest share first: the states the residual still depends on.
  std::vector<StructureTest> flagged;
  // Effect stability (empty when no effect was added or the parts could not be refit).
  bool stability_checked = false;
  std::string stability_reason;  // why not checked
  std::string parts;             // "the halves of each trace" or "the traces"
  std::vector<EffectStability> stability;
  std::vector<std::string> unstable;  // effects with an unstable parameter
  bool adequate() const { return ok && flagged.empty() && unstable.empty(); }
  // "residual depends on t (periodic, 4.5 Hz) (w: 57 % of its variance, p = 1e-40)"; "" when
  // nothing is flagged.
  std::string StructureMessage() const;
};

// The residual-structure part at `values` of `problem`.
AdequacyReport CheckResidualStructure(const FitProblem& problem, const std::vector<double>& values,
                                      const AdequacyOptions& options = {});

// Adds the stability of the parameters of `effects` (names of effects in problem's config)
// to `report`: the problem refit on two contiguous parts of the record, from `values`.
void CheckEffectStability(const FitProblem& problem, const std::vector<double>& values,
                          const std::vector<std::string>& effects, const OptimizerOptions& refit,
                          const AdequacyOptions& options, AdequacyReport* report);

// The FGLS F test of `response` on `regressors` (columns; an intercept per segment is
// added), the noise an AR(p <= ar_max_order) model fitted to the OLS residual, filtered per
// segment (`segments`: the start index of each, ascending, the first 0). Exposed for tests.
struct FglsTest {
  bool ok = false;
  double f = 0.0, p_value = 1.0, share = 0.0;
  int ar_order = 0;
};
FglsTest FglsFTest(const std::vector<double>& response,
                   const std::vector<std::vector<double>>& regressors,
                   const std::vector<std::size_t>& segments, int ar_max_order);

// The FGLS F test of `response`'s per-segment means against zero (the same AR noise model,
// fitted to the residual about the means); share: the means' part of the mean square.
FglsTest FglsMeanTest(const std::vector<double>& response, const std::vector<std::size_t>& segments,
                      int ar_max_order);

}  // namespace blmd
