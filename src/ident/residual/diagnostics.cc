#include "blmd/ident/residual/diagnostics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "blmd/ident/residual/evidence.h"
#include "blmd/ident/residual/stats.h"
#include "saturating_cast.h"

namespace blmd {
namespace {

SignDependence SplitBySign(const std::vector<double>& residual, const std::vector<double>& signal,
                           double threshold) {
  SignDependence out;
  double sum_p = 0, sum_n = 0, sq_p = 0, sq_n = 0;
  for (std::size_t k = 0; k < residual.size(); ++k) {
    if (signal[k] > threshold) {
      sum_p += residual[k];
      sq_p += residual[k] * residual[k];
      ++out.count_positive;
    } else if (signal[k] < -threshold) {
      sum_n += residual[k];
      sq_n += residual[k] * residual[k];
      ++out.count_negative;
    }
  }
  if (out.count_positive < 10 || out.count_negative < 10) return out;
  const double np = static_cast<double>(out.count_positive),
               nn = static_cast<double>(out.count_negative);
  out.mean_positive = sum_p / np;
  out.mean_negative = sum_n / nn;
  const double var_p = std::max(0.0, sq_p / np - out.mean_positive * out.mean_positive);
  const double var_n = std::max(0.0, sq_n / nn - out.mean_negative * out.mean_negative);
  const double se = std::sqrt(var_p / np + var_n / nn);
  out.t_statistic = se > 0.0 ? (out.mean_positive - out.mean_negative) / se : 0.0;
  out.available = true;
  return out;
}

// The residuals and signals of every trace, end to end.
struct PooledSignals {
  std::vector<std::vector<double>> residual;  // per observed column: measured - simulated
  std::vector<double> u;                      // measured input
  std::vector<double> w, theta, current;      // simulated (current 0 without one)
  std::vector<std::pair<std::size_t, std::size_t>> segments;  // [first, last) per trace
  std::vector<double> rates;                                  // samples per second per trace
};

// Simulates every trace at `values` and pools the signals; a failed simulation's status.
SimStatus PoolSignals(const FitProblem& problem, const std::vector<double>& values,
                      PooledSignals& pooled) {
  const auto& observe = problem.observe();
  const std::size_t columns = observe.size();
  pooled.residual.resize(columns);
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    {
      const auto& time = problem.measured(k).Column("t");
      const std::size_t first = pooled.w.size();
      pooled.segments.emplace_back(first, first + time.size());
      const double span = time.back() - time.front();
      pooled.rates.push_back(span > 0.0 ? static_cast<double>(time.size() - 1) / span : 1.0);
    }
    Trace simulated;
    SimStatus status = problem.Simulate(k, values, &simulated);
    if (!status.ok()) return status;
    const Trace& measured = problem.measured(k);
    for (std::size_t c = 0; c < columns; ++c) {
      const auto& sim = simulated.Column(observe[c]);
      const auto& meas = measured.Column(observe[c]);
      for (std::size_t r = 0; r < meas.size(); ++r) pooled.residual[c].push_back(meas[r] - sim[r]);
    }
    const auto& uk = measured.Column("u");
    pooled.u.insert(pooled.u.end(), uk.begin(), uk.end());
    const auto& wk = simulated.Column("w");
    pooled.w.insert(pooled.w.end(), wk.begin(), wk.end());
    const auto& tk = simulated.Column("theta");
    pooled.theta.insert(pooled.theta.end(), tk.begin(), tk.end());
    if (simulated.Has("i")) {
      const auto& ik = simulated.Column("i");
      pooled.current.insert(pooled.current.end(), ik.begin(), ik.end());
    } else {
      pooled.current.insert(pooled.current.end(), wk.size(), 0.0);  // rigid_load: no current
    }
  }
  return SimStatus::Ok();
}

// The largest |w|, |i| and |u|, and whether w changes sign.
void SummariseMotion(const PooledSignals& pooled, ResidualAnalysis& analysis) {
  for (double v : pooled.w) analysis.w_max = std::max(analysis.w_max, std::abs(v));
  for (double v : pooled.current) analysis.i_max = std::max(analysis.i_max, std::abs(v));
  for (double v : pooled.u) analysis.u_max = std::max(analysis.u_max, std::abs(v));
  const double w_threshold = 0.01 * analysis.w_max;  // "moving" for the sign statistics
  bool positive = false, negative = false;
  for (double v : pooled.w) {
    positive = positive || v > w_threshold;
    negative = negative || v < -w_threshold;
  }
  analysis.w_changes_sign = positive && negative;
}

// Lags of the autocorrelation and of the input cross-correlation: at most a fifth of the samples.
int ResidualLags(const std::vector<double>& e, const DiagnosticsOptions& options) {
  return std::min<int>(options.max_lag, static_cast<int>(e.size() / 5));
}

// Mean, RMS, autocorrelation and the Ljung-Box whiteness test of a residual.
void DescribeResidual(const std::vector<double>& e, const DiagnosticsOptions& options,
                      ColumnDiagnostics& d) {
  const double n = static_cast<double>(e.size());
  double sum = 0.0, sq = 0.0;
  for (double v : e) {
    sum += v;
    sq += v * v;
  }
  d.mean = sum / n;
  d.rms = std::sqrt(sq / n);
  const int lags = ResidualLags(e, options);
  d.acf = Autocorrelation(e, lags);
  d.acf_band95 = 1.959963984540054 / std::sqrt(n);
  const LjungBox test = LjungBoxTest(e, lags);
  d.ljung_box_q = test.q;
  d.ljung_box_lags = test.lags;
  d.whiteness_p = test.p_value;
}

// Cross-correlation of the residual with the input (both mean-removed, normalised) at lags
// -lags..lags, and its peak; after DescribeResidual (d.mean, d.acf_band95).
void CorrelateWithInput(const std::vector<double>& e, const std::vector<double>& u, int lags,
                        ColumnDiagnostics& d) {
  const double n = static_cast<double>(e.size());
  double u_mean = 0.0;
  for (double v : u) u_mean += v;
  u_mean /= n;
  double u_var = 0.0, e_var = 0.0;
  for (std::size_t k = 0; k < e.size(); ++k) {
    u_var += (u[k] - u_mean) * (u[k] - u_mean);
    e_var += (e[k] - d.mean) * (e[k] - d.mean);
  }
  d.input_ccf_band95 = d.acf_band95;
  if (!(u_var > 0.0 && e_var > 0.0)) return;
  const double norm = std::sqrt(u_var * e_var);
  std::vector<double> e_centred(e.size()), u_centred(e.size());
  for (std::size_t k = 0; k < e.size(); ++k) {
    e_centred[k] = e[k] - d.mean;
    u_centred[k] = u[k] - u_mean;
  }
  const long size = static_cast<long>(e.size());
  for (int lag = -lags; lag <= lags; ++lag) {
    // Sum over the k with 0 <= k - lag < size, in increasing k.
    double s = 0.0;
    for (long k = std::max(0L, static_cast<long>(lag)); k < std::min(size, size + lag); ++k) {
      s += e_centred[static_cast<std::size_t>(k)] * u_centred[static_cast<std::size_t>(k - lag)];
    }
    const double value = s / norm;
    d.input_ccf.push_back(value);
    if (std::abs(value) > std::abs(d.input_ccf_peak)) {
      d.input_ccf_peak = value;
      d.input_ccf_peak_lag = lag;
    }
  }
}

// Whitens `x` with the AR coefficients `a` (x_k - a_1 x_{k-1} - ...), from sample a.size().
std::vector<double> Whitened(const std::vector<double>& x, const std::vector<double>& a) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  std::vector<double> out;
  out.reserve(x.size());
  for (std::size_t k = a.size(); k < x.size(); ++k) {
    double v = x[k] - mean;
    for (std::size_t i = 0; i < a.size(); ++i) v -= a[i] * (x[k - 1 - i] - mean);
    out.push_back(v);
  }
  return out;
}

// The feedback test (ColumnDiagnostics::feedback_p, docs/identification.md §9).
void FeedbackInto(const std::vector<double>& e, const std::vector<double>& u, int lags,
                  ColumnDiagnostics& d) {
  if (lags < 1 || e.size() < 50 || e.size() != u.size()) return;
  // Each series whitened by its own AR model (Haugh's test of independence of two series,
  // J. Amer. Statist. Assoc. 71, 1976): the input's, and the residual's, whose slow drift where
  // the model errs would otherwise drown the noise that the loop feeds back.
  const std::vector<double> a = FitAutoregression(u, 10), b = FitAutoregression(e, 10);
  std::vector<double> alpha = Whitened(u, a), beta = Whitened(e, b);
  // Aligned at their ends: sample k of the original is alpha[k - a.size()], beta[k - b.size()].
  if (a.size() > b.size())
    beta.erase(beta.begin(), beta.begin() + static_cast<long>(a.size() - b.size()));
  if (b.size() > a.size())
    alpha.erase(alpha.begin(), alpha.begin() + static_cast<long>(b.size() - a.size()));
  const std::size_t n = alpha.size();
  double sa = 0.0, sb = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    sa += alpha[k] * alpha[k];
    sb += beta[k] * beta[k];
  }
  if (!(sa > 0.0 && sb > 0.0)) return;
  // The correlations are each N(0, 1/n) only when the whitened input spreads its power over
  // many samples: an input of a few steps whitens to a few spikes, and a slow residual then
  // correlates with each spike's neighbourhood alike. A train of s equal spikes among n
  // samples has a kurtosis of about n/s, so n / kurtosis counts the input's events; with
  // fewer than kFeedbackMinEvents the test is not made (a record of three voltage steps:
  // about 3; a PD loop's torque on a quantised encoder: 435 of 10 000 samples, kurtosis 23).
  double s4 = 0.0;
  for (double v : alpha) s4 += v * v * v * v;
  const double variance = sa / static_cast<double>(n);
  d.feedback_input_kurtosis = s4 / static_cast<double>(n) / (variance * variance);
  if (!(static_cast<double>(n) / d.feedback_input_kurtosis >= kFeedbackMinEvents)) return;
  // The residual's part that the input's past explains (a dynamic the model gets wrong: a
  // sample of a held input acts from its stamp on, so the response at k follows u up to
  // k - 1) is taken out first, by least squares on alpha(k - 1), ..., alpha(k - 1 - lags): the AR
  // model whitens a held or binary input only roughly, and without this a model error that
  // follows the input's past leaked into the future lags (7 of 20 open-loop records flagged
  // at 1e-3). Then the block alpha(k .. k + lags - 1), the input at and after the residual's
  // sample (a drive computes u(k) from the motion measured at k), is tested on what is left, by
  // the F statistic of its least squares fit (Granger's test of feedback; Ljung, System
  // Identification, 2nd ed., 1999, §13.4), its variance corrected for the colour left in
  // both series by Bartlett's factor 1 + 2 sum_k rho_alpha(k) rho_eps(k).
  const std::size_t m = static_cast<std::size_t>(lags);
  if (n < 4 * (2 * m + 2)) return;
  const std::size_t rows = n - 2 * m - 1;
  Eigen::MatrixXd past(rows, m + 1), future(rows, m);
  Eigen::VectorXd y(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    const std::size_t k = r + m + 1;
    y(static_cast<Eigen::Index>(r)) = beta[k];
    for (std::size_t j = 1; j <= m + 1; ++j)
      past(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(j - 1)) = alpha[k - j];
    for (std::size_t j = 0; j < m; ++j)
      future(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(j)) = alpha[k + j];
  }
  const Eigen::VectorXd restricted = y - past * past.colPivHouseholderQr().solve(y);
  Eigen::MatrixXd both(rows, 2 * m + 1);
  both << past, future;
  const Eigen::VectorXd full = y - both * both.colPivHouseholderQr().solve(y);
  const double sse_restricted = restricted.squaredNorm(), sse_full = full.squaredNorm();
  if (!(sse_full > 0.0) || !std::isfinite(sse_restricted)) return;
  const int memory = std::min<int>(50, static_cast<int>(rows / 5));
  const std::vector<double> eps(restricted.data(), restricted.data() + rows);
  const std::vector<double> rho_alpha = Autocorrelation(alpha, memory);
  const std::vector<double> rho_eps = Autocorrelation(eps, memory);
  double inflation = 1.0;
  for (std::size_t k = 0; k < rho_alpha.size() && k < rho_eps.size(); ++k)
    inflation += 2.0 * rho_alpha[k] * rho_eps[k];
  inflation = std::max(inflation, 1.0);
  // The correlations of what is left with the input's future, for the report.
  double se = 0.0, sf = 0.0;
  for (std::size_t r = 0; r < rows; ++r) {
    se += eps[r] * eps[r];
    sf += alpha[r + m + 1] * alpha[r + m + 1];
  }
  const double norm = std::sqrt(se * sf);
  for (std::size_t j = 0; j < m && norm > 0.0; ++j) {
    double sum = 0.0;
    for (std::size_t r = 0; r < rows; ++r) sum += eps[r] * alpha[r + m + 1 + j];
    const double value = sum / norm;
    d.future_ccf.push_back(value);
    if (std::abs(value) > std::abs(d.feedback_peak)) {
      d.feedback_peak = value;
      d.feedback_peak_lead = static_cast<int>(j);
    }
  }
  const double dof = static_cast<double>(rows - (2 * m + 1));
  const double chi2 = (sse_restricted - sse_full) / (sse_full / dof) / inflation;
  d.feedback_p = ChiSquareSurvival(std::max(chi2, 0.0), lags);
}

// The residual in steady motion (|w| above a quarter of its maximum) after the angle-
// synchronous detrend: from each sample, the residual's mean over one shaft revolution around
// it (half-width pi/|w| in time). `use` marks those samples, `moving` counts them.
std::vector<double> DetrendOverRevolution(const std::vector<double>& e, const PooledSignals& pooled,
                                          double w_max, std::vector<char>& use,
                                          std::size_t& moving) {
  const std::vector<double>& w = pooled.w;
  std::vector<double> detrended(e.size(), 0.0);
  use.assign(e.size(), 0);
  moving = 0;
  for (std::size_t s_index = 0; s_index < pooled.segments.size(); ++s_index) {
    const auto [first, last] = pooled.segments[s_index];
    std::vector<double> prefix(last - first + 1, 0.0);
    for (std::size_t k = first; k < last; ++k) prefix[k - first + 1] = prefix[k - first] + e[k];
    const std::size_t cap = std::max<std::size_t>(1, (last - first) / 4);
    for (std::size_t k = first; k < last; ++k) {
      if (std::abs(w[k]) <= 0.25 * w_max) continue;
      const std::size_t h = std::min(cap, internal::SaturatingCast<std::size_t>(
                                              M_PI / std::abs(w[k]) * pooled.rates[s_index]));
      const std::size_t lo = k - first >= h ? k - first - h : 0;
      const std::size_t hi = std::min(last - first, k - first + h + 1);
      detrended[k] = e[k] - (prefix[hi] - prefix[lo]) / static_cast<double>(hi - lo);
      use[k] = 1;
      ++moving;
    }
  }
  return detrended;
}

// Amplitude of orders 1..max_order of the detrended residual over theta (harmonic regression
// on the samples in use); orders below min_order are left at 0.
std::vector<double> OrderAmplitudes(const std::vector<double>& detrended,
                                    const std::vector<char>& use, std::size_t moving,
                                    const std::vector<double>& theta, int min_order,
                                    int max_order_option) {
  // One cosine and sine per sample; the orders' cos(n theta), sin(n theta) by the
  // rotation recurrence (rounding grows by about one ulp per order, < 1e-13 at order 64).
  const auto max_order = static_cast<std::size_t>(max_order_option);
  std::vector<double> a(max_order + 1, 0.0), b(max_order + 1, 0.0);
  for (std::size_t k = 0; k < detrended.size(); ++k) {
    if (!use[k]) continue;
    const double c1 = std::cos(theta[k]), s1 = std::sin(theta[k]);
    double c = 1.0, s = 0.0;
    for (std::size_t order = 1; order <= max_order; ++order) {
      const double c_next = c * c1 - s * s1;
      s = s * c1 + c * s1;
      c = c_next;
      a[order] += detrended[k] * c;
      b[order] += detrended[k] * s;
    }
  }
  std::vector<double> amplitude(max_order, 0.0);
  const double scale = 2.0 / static_cast<double>(std::max<std::size_t>(moving, 1));
  for (int order = min_order; order <= max_order_option; ++order) {
    const auto n = static_cast<std::size_t>(order);
    amplitude[n - 1] = scale * std::hypot(a[n], b[n]);
  }
  return amplitude;
}

// The `options.peaks` largest orders, each against the median amplitude of the resolved orders.
std::vector<AnglePeak> LargestPeaks(const std::vector<double>& amplitude, int min_order,
                                    const DiagnosticsOptions& options, double pole_pairs) {
  std::vector<double> sorted(
      amplitude.begin() + std::min<long>(min_order - 1, options.max_order - 1), amplitude.end());
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double floor = sorted[sorted.size() / 2];
  std::vector<int> orders(amplitude.size());
  for (std::size_t k = 0; k < orders.size(); ++k) orders[k] = static_cast<int>(k + 1);
  std::stable_sort(orders.begin(), orders.end(), [&](int l, int r) {
    return amplitude[static_cast<std::size_t>(l - 1)] > amplitude[static_cast<std::size_t>(r - 1)];
  });
  std::vector<AnglePeak> peaks;
  for (int k = 0; k < options.peaks && k < static_cast<int>(orders.size()); ++k) {
    AnglePeak peak;
    peak.order = orders[static_cast<std::size_t>(k)];
    peak.amplitude = amplitude[static_cast<std::size_t>(peak.order - 1)];
    peak.ratio = floor > 0.0 ? peak.amplitude / floor : 0.0;
    peak.electrical_multiple = pole_pairs > 0.0 ? peak.order / pole_pairs : 0.0;
    peaks.push_back(peak);
  }
  return peaks;
}

// Angle spectrum: harmonic regression of the residual on theta over the samples in steady
// motion, after the angle-synchronous detrend (DetrendOverRevolution), which cancels every
// whole order and keeps the slow drift out (transients after a step or a reversal would
// otherwise smear all orders alike). Orders that complete fewer than three periods over the
// whole rotation are not resolved; the spectrum needs at least half a revolution.
// Orders above the samples' Nyquist order in angle (AngleNyquistOrder) are aliased and left
// out too.
void AngleSpectrum(const std::vector<double>& e, const PooledSignals& pooled, double theta_span,
                   double w_max, int nyquist_order, const DiagnosticsOptions& all_options,
                   double pole_pairs, ColumnDiagnostics& d) {
  d.shaft_turned = theta_span > M_PI;
  // A shaft that barely turned (a locked rotor: theta_span ~ 0) gives a huge ratio.
  const int min_order = std::max(
      1, internal::SaturatingCast<int>(std::ceil(3.0 * 2.0 * M_PI / std::max(theta_span, 1e-9))));
  if (!d.shaft_turned) return;
  DiagnosticsOptions options = all_options;
  if (nyquist_order > 0) options.max_order = std::min(options.max_order, nyquist_order);
  if (options.max_order < min_order) return;
  std::vector<char> use;
  std::size_t moving = 0;
  const std::vector<double> detrended = DetrendOverRevolution(e, pooled, w_max, use, moving);
  const std::vector<double> amplitude =
      OrderAmplitudes(detrended, use, moving, pooled.theta, min_order, options.max_order);
  d.angle_peaks = LargestPeaks(amplitude, min_order, options, pole_pairs);
}

}  // namespace

ResidualAnalysis AnalyseResidual(const FitProblem& problem, const std::vector<double>& values,
                                 const DiagnosticsOptions& options) {
  ResidualAnalysis analysis;
  PooledSignals pooled;
  const SimStatus status = PoolSignals(problem, values, pooled);
  if (!status.ok()) {
    analysis.reason = status.message;
    return analysis;
  }
  SummariseMotion(pooled, analysis);
  const double pole_pairs = problem.config().parameters.GetOr("p", 0.0);
  double theta_span = 0.0;
  for (std::size_t k = 1; k < pooled.theta.size(); ++k) {
    theta_span += std::abs(pooled.theta[k] - pooled.theta[k - 1]);
  }

  analysis.angle_nyquist_order = AngleNyquistOrder(problem.traces());
  const auto& observe = problem.observe();
  const std::size_t columns = observe.size();
  double min_p = 1.0, min_feedback_p = 1.0;
  for (std::size_t c = 0; c < columns; ++c) {
    const std::vector<double>& e = pooled.residual[c];
    ColumnDiagnostics d;
    d.column = observe[c];
    DescribeResidual(e, options, d);
    min_p = std::min(min_p, d.whiteness_p);
    CorrelateWithInput(e, pooled.u, ResidualLags(e, options), d);
    // The equation error's residual is in the input's units, made from the input itself.
    if (!problem.equation_error()) FeedbackInto(e, pooled.u, ResidualLags(e, options), d);
    min_feedback_p = std::min(min_feedback_p, d.feedback_p);
    d.sign_w = SplitBySign(e, pooled.w, 0.01 * analysis.w_max);
    d.sign_i = SplitBySign(e, pooled.current, 0.01 * analysis.i_max);
    AngleSpectrum(e, pooled, theta_span, analysis.w_max, analysis.angle_nyquist_order, options,
                  pole_pairs, d);
    analysis.columns.push_back(d);
  }
  analysis.whiteness_p = std::min(1.0, min_p * static_cast<double>(columns));
  analysis.white = analysis.whiteness_p >= 0.05;
  analysis.feedback_p = std::min(1.0, min_feedback_p * static_cast<double>(columns));
  analysis.closed_loop = analysis.feedback_p < 1e-3;
  analysis.ok = true;
  return analysis;
}

ColumnDiagnostics TestFeedback(const std::vector<double>& residual, const std::vector<double>& u,
                               int lags) {
  ColumnDiagnostics d;
  FeedbackInto(residual, u, lags, d);
  return d;
}

}  // namespace blmd
