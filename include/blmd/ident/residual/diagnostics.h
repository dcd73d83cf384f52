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
};

struct DiagnosticsOptions {
  int max_lag = 20;
  int max_order = 64;  // angle spectrum orders 1..max_order
  int peaks = 5;
};

ResidualAnalysis AnalyseResidual(const FitProblem& problem, const std::vector<double>& values,
                                 const DiagnosticsOptions& options = {});

}  // namespace blmd
