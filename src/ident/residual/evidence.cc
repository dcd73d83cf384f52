#include "blmd/ident/residual/evidence.h"

#include <algorithm>
#include <cmath>

#include "blmd/ident/fit/problem.h"

namespace blmd {

std::vector<double> FitAutoregression(const std::vector<double>& series, int max_order) {
  const std::size_t n = series.size();
  if (n < 4 || max_order <= 0) return {};
  double mean = 0.0;
  for (double v : series) mean += v;
  mean /= static_cast<double>(n);
  const int orders = std::min<int>(max_order, static_cast<int>(n / 4));
  std::vector<double> gamma(static_cast<std::size_t>(orders) + 1, 0.0);
  for (int lag = 0; lag <= orders; ++lag) {
    double sum = 0.0;
    for (std::size_t t = static_cast<std::size_t>(lag); t < n; ++t) {
      sum += (series[t] - mean) * (series[t - static_cast<std::size_t>(lag)] - mean);
    }
    gamma[static_cast<std::size_t>(lag)] = sum / static_cast<double>(n);  // biased: stable
  }
  if (!(gamma[0] > 0.0) || !std::isfinite(gamma[0])) return {};
  // Levinson-Durbin: a holds the AR(p) coefficients, sigma2 its innovation variance.
  std::vector<double> a, best;
  double sigma2 = gamma[0];
  const double log_n = std::log(static_cast<double>(n));
  double best_score = static_cast<double>(n) * std::log(sigma2);
  for (int p = 1; p <= orders; ++p) {
    double acc = gamma[static_cast<std::size_t>(p)];
    for (int j = 1; j < p; ++j) {
      acc -= a[static_cast<std::size_t>(j - 1)] * gamma[static_cast<std::size_t>(p - j)];
    }
    const double k = acc / sigma2;
    if (!std::isfinite(k) || std::abs(k) >= 1.0) break;  // numerically singular
    std::vector<double> next(static_cast<std::size_t>(p));
    for (int j = 1; j < p; ++j) {
      next[static_cast<std::size_t>(j - 1)] =
          a[static_cast<std::size_t>(j - 1)] - k * a[static_cast<std::size_t>(p - j - 1)];
    }
    next[static_cast<std::size_t>(p - 1)] = k;
    a = std::move(next);
    sigma2 *= 1.0 - k * k;
    if (!(sigma2 > 0.0)) break;
    const double score = static_cast<double>(n) * std::log(sigma2) + p * log_n;
    if (score < best_score) {
      best_score = score;
      best = a;
    }
  }
  return best;
}

namespace {

// Sum of squares of the whitened series (from t = p on) and the count.
void AddWhitened(const double* r, std::size_t rows, const std::vector<double>& a, double* sum,
                 double* count) {
  const std::size_t p = a.size();
  for (std::size_t t = p; t < rows; ++t) {
    double e = r[t];
    for (std::size_t j = 0; j < p; ++j) e -= a[j] * r[t - 1 - j];
    *sum += e * e;
  }
  *count += static_cast<double>(rows > p ? rows - p : 0);
}

}  // namespace

WhitenedEvidence PrewhitenedEvidence(const std::vector<double>& base_residuals,
                                     std::size_t base_free, const FitProblem& candidate,
                                     const std::vector<double>& candidate_values) {
  // Order 2 at most: enough for a sensor's or filter's short memory; higher orders begin to
  // describe the model error's own slow structure and then absorb any effect's signature
  // (docs/discovery.md: on the ODrive records order 8 hid a 7/rev cogging that order 2 finds).
  constexpr int kMaxOrder = 2;
  WhitenedEvidence out;
  std::vector<double> r_candidate;
  const Evaluation ec = candidate.Evaluate(candidate_values, &r_candidate);
  if (!ec.ok || base_residuals.size() != r_candidate.size()) {
    out.reason = !ec.ok ? ec.reason : "the residuals do not match";
    return out;
  }
  const std::size_t columns = candidate.observe().size();
  std::vector<double> sse_base(columns, 0.0), sse_candidate(columns, 0.0), count(columns, 0.0);
  std::vector<double> raw_candidate(columns, 0.0), raw_count(columns, 0.0);
  out.order.assign(columns, 0);
  std::size_t at = 0;
  for (std::size_t k = 0; k < candidate.traces().size(); ++k) {
    const std::size_t rows = candidate.measured(k).rows();
    for (std::size_t c = 0; c < columns; ++c) {
      const double* rb = base_residuals.data() + at;
      const double* rc = r_candidate.data() + at;
      const std::vector<double> a =
          FitAutoregression(std::vector<double>(rc, rc + rows), kMaxOrder);
      out.order[c] = std::max(out.order[c], static_cast<int>(a.size()));
      AddWhitened(rb, rows, a, &sse_base[c], &count[c]);
      double unused = 0.0;
      AddWhitened(rc, rows, a, &sse_candidate[c], &unused);
      for (std::size_t t = 0; t < rows; ++t) raw_candidate[c] += rc[t] * rc[t];
      raw_count[c] += static_cast<double>(rows);
      at += rows;
    }
  }
  if (at != r_candidate.size()) {
    out.reason = "the residuals do not match the traces";
    return out;
  }
  // A sum of squares below 1e-12 of the column's variance per sample is the simulator's
  // precision (see Bic in discovery.cc); residuals are weighted by 1/sqrt(C N_c Var_c).
  double total = 0.0;
  for (std::size_t c = 0; c < columns; ++c) {
    const double floor = std::max(1e-12 * count[c] / (columns * raw_count[c]), 1e-300);
    out.delta_bic +=
        count[c] * std::log(std::max(sse_candidate[c], floor) / std::max(sse_base[c], floor));
    out.innovation_ratio.push_back(raw_candidate[c] > 0.0
                                       ? (sse_candidate[c] / std::max(count[c], 1.0)) /
                                             (raw_candidate[c] / raw_count[c])
                                       : 1.0);
    total += count[c];
  }
  const double added = static_cast<double>(candidate.num_free()) - static_cast<double>(base_free);
  out.delta_bic += added * std::log(std::max(total, 1.0));
  out.ok = true;
  return out;
}

}  // namespace blmd
