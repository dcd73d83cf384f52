// The input-residual test (docs/discovery.md §7b): does the residual follow the input's past?
//
// The adequacy check's bases ask what the residual depends on *now* (the angle, the speed,
// the input's level, the time). Dynamics the model lacks (a flexible coupling's resonance, a
// lag in the sensor or in the current loop, a filter) make the residual a response to the
// input's *history* instead, and noise does not: measurement noise, coloured or not, is
// independent of an open-loop input, and in a closed loop the innovation at sample k is
// independent of the input up to k - 1, which the drive computed from earlier measurements.
// This is the cross-correlation test every identification toolbox runs beside the
// autocorrelation (Ljung, System Identification, 2nd ed., 1999, §16.6; MATLAB's resid), in
// the form of Haugh (J. Amer. Statist. Assoc. 71, 1976): the input and the residual are each
// whitened by their own autoregressive model (Yule-Walker, order <= 10 by BIC), and the
// whitened residual beta(k) is regressed on the whitened input's past alpha(k-1) ..
// alpha(k-L). Its statistic
//   X = (SSE_0 - SSE_1) / (SSE_1 / (n - L - 1)) / c,   c = 1 + 2 sum_j rho_alpha(j) rho_eps(j)
// (Bartlett's factor for the colour left in both series) is referred to chi^2(L). L = 25
// lags by default, resid's M. A held input sample acts from its stamp on, so a response at
// k follows u up to k - 1: lag 0 is left to the feedback test (diagnostics.h).
//
// The share is the part of the residual's variance that follows the input: the fitted
// response to the whitened input's past, coloured back by the inverse of the residual's
// whitening filter, against the residual's variance (about L/n for noise alone, as is the
// whitened share 1 - SSE_1/SSE_0). Where the residual is
// follows the input most says where the missing dynamics lie: the peak gain of that fitted
// response, H(f) A(f) / B(f) (the lags' coefficients, and the input's and the residual's
// whitening polynomials), over the frequencies the input drives.
#pragma once

#include <cstddef>
#include <vector>

namespace blmd {

struct InputPastTest {
  bool ok = false;
  int lags = 0;                 // L: alpha(k-1) .. alpha(k-L)
  double statistic = 0.0;       // X, chi^2(L) under no dependence
  double p_value = 1.0;         // one test, no family factor
  double share = 0.0;           // of the residual's variance, the part that follows the input
  double whitened_share = 0.0;  // 1 - SSE_1/SSE_0 of the whitened residual
  int ar_order = 0;             // of the residual's whitening model
  // corr(beta(k), alpha(k - j)), j = 1..L, and the two-sided 95 % band 1.96/sqrt(n) they are
  // drawn against (as resid draws them); the largest in size and its lag.
  std::vector<double> ccf;
  double band95 = 0.0;
  int peak_lag = 0;
  double peak = 0.0;
  double frequency_hz = 0.0;  // of the residual's largest response to u (0: not estimated)
};

// The test of `residual` against the input `u` (pooled over traces whose first rows are
// `segments`; rows whose lags reach back across a trace's start are left out), sampled at
// `sample_rate_hz` (0 when the traces' rates differ: no frequency), over `lags` lags.
// Not ok with fewer than 8 (L + 2) rows, or when either series is constant.
InputPastTest TestInputPast(const std::vector<double>& residual, const std::vector<double>& u,
                            const std::vector<std::size_t>& segments, double sample_rate_hz,
                            int lags);

}  // namespace blmd
