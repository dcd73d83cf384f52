#include "blmd/ident/residual/input_residual.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <span>

#include "blmd/ident/residual/evidence.h"
#include "blmd/ident/residual/spectral.h"
#include "blmd/ident/residual/stats.h"

namespace blmd {
namespace {

constexpr int kWhiteningOrder = 10;  // the largest AR order of either series' whitening model

// x whitened by the AR coefficients `a` (x_k - a_1 x_{k-1} - ..., about x's mean), trace by
// trace: the first a.size() rows of each trace have no past and are NaN.
std::vector<double> WhitenedPerTrace(const std::vector<double>& x, const std::vector<double>& a,
                                     const std::vector<std::size_t>& segments) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  std::vector<double> out(x.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t first = segments[s];
    const std::size_t last = s + 1 < segments.size() ? segments[s + 1] : x.size();
    for (std::size_t k = first + a.size(); k < last; ++k) {
      double v = x[k] - mean;
      for (std::size_t i = 0; i < a.size(); ++i) v -= a[i] * (x[k - 1 - i] - mean);
      out[k] = v;
    }
  }
  return out;
}

// Where the residual follows the input most: the peak gain of the residual's fitted response
// to the input, G(f) = H(f) A(f) / B(f), with H the fitted response to the whitened input's
// past (the lags' coefficients), A the input's whitening filter and B the residual's (their
// AR polynomials at z = exp(-i 2 pi f / fs)): the frequency response of what the model lacks,
// parametric so that a chirp, which drives each frequency in one Welch segment only, is read
// as well as a PRBS. Searched over the Welch bins (EstimateWelchSpectra) where the input has at
// least 1e-3 of its largest density: elsewhere the response is not seen in the data.
void ResponsePeak(const std::vector<double>& u, const std::vector<std::size_t>& segments,
                  double sample_rate_hz, const Eigen::VectorXd& h, const std::vector<double>& a,
                  const std::vector<double>& b, InputPastTest* test) {
  if (!(sample_rate_hz > 0.0)) return;
  std::vector<SpectralRecord> records;
  std::size_t longest = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t first = segments[s];
    const std::size_t last = s + 1 < segments.size() ? segments[s + 1] : u.size();
    longest = std::max(longest, last - first);
    SpectralRecord record;
    record.input = std::span<const double>(u.data() + first, last - first);
    records.push_back(std::move(record));
  }
  const std::size_t length = WelchSegmentLength(longest);
  if (length == 0) return;
  const WelchSpectra spectra = EstimateWelchSpectra(records, sample_rate_hz, length);
  if (!spectra.ok) return;
  const double input_max = *std::max_element(spectra.input_psd.begin(), spectra.input_psd.end());
  auto polynomial = [](const std::vector<double>& c, std::complex<double> z) {
    std::complex<double> value = 1.0, power = 1.0;
    for (double ci : c) {
      power *= z;
      value -= ci * power;
    }
    return value;
  };
  double best = 0.0;
  for (std::size_t k = 0; k < spectra.f_hz.size(); ++k) {
    if (!(spectra.input_psd[k] >= 1e-3 * input_max)) continue;
    const std::complex<double> z = std::polar(1.0, -2.0 * M_PI * spectra.f_hz[k] / sample_rate_hz);
    std::complex<double> response = 0.0, power = 1.0;
    for (Eigen::Index j = 1; j < h.size(); ++j) {
      power *= z;
      response += h(j) * power;
    }
    const double gain = std::abs(response * polynomial(a, z) / polynomial(b, z));
    if (std::isfinite(gain) && gain > best) {
      best = gain;
      test->frequency_hz = spectra.f_hz[k];
    }
  }
}

}  // namespace

InputPastTest TestInputPast(const std::vector<double>& residual, const std::vector<double>& u,
                            const std::vector<std::size_t>& segments, double sample_rate_hz,
                            int lags) {
  InputPastTest test;
  const std::size_t n = residual.size();
  if (lags < 1 || u.size() != n || segments.empty() || n < 8 * static_cast<std::size_t>(lags + 2))
    return test;
  const auto [u_low, u_high] = std::minmax_element(u.begin(), u.end());
  if (!(*u_high > *u_low)) return test;  // a constant input: nothing to follow
  const std::vector<double> a = FitAutoregression(u, kWhiteningOrder);
  const std::vector<double> b = FitAutoregression(residual, kWhiteningOrder);
  const std::vector<double> alpha = WhitenedPerTrace(u, a, segments);
  const std::vector<double> beta = WhitenedPerTrace(residual, b, segments);
  test.ar_order = static_cast<int>(b.size());
  // The rows whose response and every lag lie in one trace, with both series defined.
  const auto L = static_cast<std::size_t>(lags);
  std::vector<std::size_t> rows;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t first = segments[s];
    const std::size_t last = s + 1 < segments.size() ? segments[s + 1] : n;
    for (std::size_t k = first + L + std::max(a.size(), b.size()); k < last; ++k) rows.push_back(k);
  }
  const auto m = static_cast<Eigen::Index>(L);
  const auto count = static_cast<Eigen::Index>(rows.size());
  if (count < 8 * (m + 2)) return test;
  Eigen::MatrixXd X(count, m + 1);
  Eigen::VectorXd y(count);
  for (Eigen::Index r = 0; r < count; ++r) {
    const std::size_t k = rows[static_cast<std::size_t>(r)];
    y(r) = beta[k];
    X(r, 0) = 1.0;
    for (std::size_t j = 1; j <= L; ++j) X(r, static_cast<Eigen::Index>(j)) = alpha[k - j];
  }
  if (!y.allFinite() || !X.allFinite()) return test;
  const Eigen::VectorXd centred = y.array() - y.mean();
  const double sse0 = centred.squaredNorm();
  double alpha_power = 0.0;
  for (Eigen::Index r = 0; r < count; ++r) alpha_power += X(r, 1) * X(r, 1);
  if (!(sse0 > 0.0) || !(alpha_power > 0.0)) return test;
  const Eigen::VectorXd h = X.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd eps = y - X * h;
  const double sse1 = eps.squaredNorm();
  if (!(sse1 > 0.0) || !std::isfinite(sse1)) return test;
  // Bartlett's factor for the colour left in the whitened input and in what is left of the
  // residual (Ljung 1999, §16.6: the variance of a cross-correlation is sum rho_u rho_e / n).
  const int memory = std::min<int>(50, static_cast<int>(count / 5));
  std::vector<double> alpha_rows(static_cast<std::size_t>(count));
  for (Eigen::Index r = 0; r < count; ++r) alpha_rows[static_cast<std::size_t>(r)] = X(r, 1);
  const std::vector<double> rho_alpha = Autocorrelation(alpha_rows, memory);
  const std::vector<double> rho_eps =
      Autocorrelation(std::vector<double>(eps.data(), eps.data() + count), memory);
  double inflation = 1.0;
  for (std::size_t k = 0; k < rho_alpha.size() && k < rho_eps.size(); ++k)
    inflation += 2.0 * rho_alpha[k] * rho_eps[k];
  inflation = std::max(inflation, 1.0);
  const double dof = static_cast<double>(count - m - 1);
  test.statistic = std::max(0.0, (sse0 - sse1) / (sse1 / dof) / inflation);
  test.p_value = ChiSquareSurvival(test.statistic, lags);
  test.whitened_share = std::clamp(1.0 - sse1 / sse0, 0.0, 1.0);
  // The residual's part that follows the input, in the residual's own units: the fitted
  // response to the whitened input's past, coloured back by the inverse of the residual's
  // whitening filter (Yule-Walker's AR model is stable, so this recursion is too), trace by
  // trace; its share of the residual's variance over the rows tested.
  {
    std::vector<double> part(n, 0.0);
    std::vector<char> tested(n, 0);
    for (std::size_t k : rows) tested[k] = 1;
    double part_sum = 0.0, part_sq = 0.0, e_sum = 0.0, e_sq = 0.0;
    for (std::size_t s = 0; s < segments.size(); ++s) {
      const std::size_t first = segments[s];
      const std::size_t last = s + 1 < segments.size() ? segments[s + 1] : n;
      for (std::size_t k = first; k < last; ++k) {
        if (!tested[k]) continue;
        double v = 0.0;
        for (std::size_t j = 1; j <= L; ++j) v += h(static_cast<Eigen::Index>(j)) * alpha[k - j];
        for (std::size_t i = 0; i < b.size() && k >= first + i + 1; ++i)
          v += b[i] * part[k - 1 - i];
        part[k] = v;
        part_sum += v;
        part_sq += v * v;
        e_sum += residual[k];
        e_sq += residual[k] * residual[k];
      }
    }
    const double rows_n = static_cast<double>(count);
    const double part_var = part_sq / rows_n - (part_sum / rows_n) * (part_sum / rows_n);
    const double e_var = e_sq / rows_n - (e_sum / rows_n) * (e_sum / rows_n);
    test.share =
        e_var > 0.0 && std::isfinite(part_var) ? std::clamp(part_var / e_var, 0.0, 1.0) : 0.0;
  }
  test.lags = lags;
  // The correlations, for the report and the plot.
  const double ybar = y.mean();
  for (std::size_t j = 1; j <= L; ++j) {
    double sxy = 0.0, sxx = 0.0;
    for (Eigen::Index r = 0; r < count; ++r) {
      const double x = alpha[rows[static_cast<std::size_t>(r)] - j];
      sxy += (y(r) - ybar) * x;
      sxx += x * x;
    }
    const double value = sxx > 0.0 ? sxy / std::sqrt(sxx * sse0) : 0.0;
    test.ccf.push_back(value);
    if (std::abs(value) > std::abs(test.peak)) {
      test.peak = value;
      test.peak_lag = static_cast<int>(j);
    }
  }
  test.band95 = 1.959963984540054 / std::sqrt(static_cast<double>(count));
  ResponsePeak(u, segments, sample_rate_hz, h, a, b, &test);
  test.ok = std::isfinite(test.statistic) && std::isfinite(test.p_value);
  return test;
}

}  // namespace blmd
