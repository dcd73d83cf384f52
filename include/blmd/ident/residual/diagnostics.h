// Residual diagnostics (docs/discovery.md): what is left after a fit, and where it comes
// from. Residual = measured - simulated, per observed column, over all traces.
#pragma once

#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd {

struct AnglePeak {
  int order = 0;                     // periods per shaft revolution
  double electrical_multiple = 0.0;  // order / p (blmd), else 0
  double amplitude = 0.0;            // residual amplitude at that order, column units
  double ratio = 0.0;                // amplitude / noise floor (median amplitude over orders)
};

struct SignDependence {
  bool available = false;
  double mean_positive = 0.0, mean_negative = 0.0;  // residual mean where the signal > 0 / < 0
  long count_positive = 0, count_negative = 0;
  double t_statistic = 0.0;  // of the difference, Welch
};

struct ColumnDiagnostics {
  std::string column;
  double mean = 0.0, rms = 0.0;
  std::vector<double> acf;  // lags 1..L
  double acf_band95 = 0.0;
  double ljung_box_q = 0.0;
  int ljung_box_lags = 0;
  double whiteness_p = 1.0;
  std::vector<double> input_ccf;  // lags -L..L: corr(residual[k], u[k - lag])
  double input_ccf_band95 = 0.0;
  int input_ccf_peak_lag = 0;
  double input_ccf_peak = 0.0;
  // Feedback (docs/identification.md §9): the residual against the input's future, after
  // both are prewhitened by the input's AR model. In open loop the input does not depend on
  // the residual, and its later values are uncorrelated with it; in closed loop the drive
  // computed u from the measured motion, noise included, so later u follows the residual.
  // future_ccf[j] = corr(residual[k], u[k + j]) of the prewhitened series, j = 0..L-1, after
  // the residual's part that u's past explains is taken out (a sampled drive computes u(k)
  // from the motion measured at k, so lead 0 is feedback: a held input acts from its stamp);
  // feedback_p = P(chi2_L > n sum r_future^2) (Box & Jenkins' test for feedback; Ljung,
  // System Identification, 2nd ed., 1999, §16.6); 1 when not computed.
  std::vector<double> future_ccf;
  double feedback_p = 1.0;
  double feedback_input_kurtosis = 0.0;  // of the whitened input (kFeedbackMinEvents)
  int feedback_peak_lead = 0;            // samples by which the most correlated u follows (0: same)
  double feedback_peak = 0.0;
  SignDependence sign_w, sign_i;
  std::vector<AnglePeak> angle_peaks;  // strongest first
  bool shaft_turned = false;           // enough rotation for an angle spectrum
};

struct ResidualAnalysis {
  bool ok = false;
  std::string reason;
  std::vector<ColumnDiagnostics> columns;
  double whiteness_p = 1.0;     // min over columns x number of columns (Bonferroni), <= 1
  bool white = true;            // whiteness_p >= 0.05
  bool w_changes_sign = false;  // the simulated speed takes both signs
  double w_max = 0.0;           // max |simulated w|, rad/s
  double i_max = 0.0;           // max |simulated i|, A
  double u_max = 0.0;           // max |u|
  int angle_nyquist_order = 0;  // the traces' AngleNyquistOrder (problem.h); 0: no angle
  // The smallest column's feedback_p times the number of columns (Bonferroni), <= 1, and
  // whether it is below 1e-3: the record looks closed loop (u computed from the motion).
  double feedback_p = 1.0;
  bool closed_loop = false;
};

struct DiagnosticsOptions {
  int max_lag = 20;
  int max_order = 64;  // angle spectrum orders 1..max_order
  int peaks = 5;
};

// The feedback test needs an input of at least this many events: samples / kurtosis of the
// whitened input (a train of s equal spikes has a kurtosis of about n/s).
inline constexpr double kFeedbackMinEvents = 100.0;

// The feedback test of one residual against the input (ColumnDiagnostics::future_ccf,
// feedback_p), over `lags` later samples; feedback_p stays 1 with fewer than 50 samples.
ColumnDiagnostics TestFeedback(const std::vector<double>& residual, const std::vector<double>& u,
                               int lags);

ResidualAnalysis AnalyseResidual(const FitProblem& problem, const std::vector<double>& values,
                                 const DiagnosticsOptions& options = {});

}  // namespace blmd
