#include "blmd/ident/residual/adequacy.h"

#include <Eigen/Dense>
#include <algorithm>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <unsupported/Eigen/FFT>

#include "blmd/constants.h"
#include "blmd/ident/residual/evidence.h"
#include "blmd/ident/residual/input_residual.h"
#include "blmd/io/csv.h"
#include "blmd/sim/effects.h"
#include "ident/residual/record_parts.h"

namespace blmd {
namespace {

std::string G(double v, int digits = 3) { return FormatSignificant(v, digits); }

// What the tests see of the record, pooled over the traces: the states at every compared
// sample and each observed column's residual.
struct Pooled {
  std::vector<std::size_t> segments;  // start of each trace
  std::vector<double> t, u, w, theta;
  bool has_w = false, has_theta = false;
  std::vector<std::vector<double>> residual;  // per observed column
  std::vector<double> dt;                     // per trace, mean sample interval, s
  bool input_past = false;  // make the u (past) test (an output-error fit with an input)
  // u (past) results per column, kept for the flagged test's plot.
  std::vector<InputPastTest> past;
};

bool Gather(const FitProblem& problem, const std::vector<double>& values, Pooled* pooled,
            std::string* reason) {
  const auto& observe = problem.observe();
  pooled->residual.assign(observe.size(), {});
  pooled->has_w = pooled->has_theta = true;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    Trace simulated;
    const SimStatus status = problem.Simulate(k, values, &simulated);
    if (!status.ok()) {
      *reason = "the model could not be simulated: " + status.message;
      return false;
    }
    const Trace& measured = problem.measured(k);
    const std::size_t n = measured.rows();
    if (simulated.rows() != n || n < 8) {
      *reason = "a trace is too short to test";
      return false;
    }
    pooled->segments.push_back(pooled->t.size());
    const auto& t = measured.Column("t");
    // The states the residual is tested against: the simulated ones where the model gives
    // them. A measured speed carries the very noise whose residual is tested: binned on
    // measured w, AR(1) noise of 0.95 "depended on w" in 11 of 40 controls (p down to 1e-42).
    // Measured only under the equation error, whose simulation gives the input.
    auto state = [&](const char* name) -> const std::vector<double>* {
      if (simulated.Has(name)) return &simulated.Column(name);
      if (measured.Has(name)) return &measured.Column(name);
      return nullptr;
    };
    const std::vector<double>* w = state("w");
    const std::vector<double>* theta = state("theta");
    const std::vector<double>* u = measured.Has("u") ? &measured.Column("u") : nullptr;
    pooled->has_w = pooled->has_w && w;
    pooled->has_theta = pooled->has_theta && theta;
    pooled->dt.push_back((t.back() - t.front()) / static_cast<double>(n - 1));
    for (std::size_t r = 0; r < n; ++r) {
      pooled->t.push_back(t[r]);
      pooled->u.push_back(u ? (*u)[r] : 0.0);
      pooled->w.push_back(w ? (*w)[r] : 0.0);
      pooled->theta.push_back(theta ? (*theta)[r] : 0.0);
    }
    for (std::size_t c = 0; c < observe.size(); ++c) {
      const auto& m = measured.Column(observe[c]);
      const auto& s = simulated.Column(observe[c]);
      for (std::size_t r = 0; r < n; ++r) pooled->residual[c].push_back(m[r] - s[r]);
    }
  }
  return true;
}

// Indicator columns of the quantile bins of x (the lowest bin left to the intercepts).
std::vector<std::vector<double>> QuantileBins(const std::vector<double>& x, int bins) {
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> edges;
  for (int b = 1; b < bins; ++b) {
    const double edge = sorted[static_cast<std::size_t>(static_cast<double>(b) / bins *
                                                        static_cast<double>(sorted.size() - 1))];
    if (edges.empty() || edge > edges.back()) edges.push_back(edge);
  }
  std::vector<std::vector<double>> columns;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    std::vector<double> column(x.size(), 0.0);
    std::size_t count = 0;
    for (std::size_t r = 0; r < x.size(); ++r) {
      const bool above = x[r] > edges[e];
      const bool below_next = e + 1 == edges.size() || x[r] <= edges[e + 1];
      if (above && below_next) {
        column[r] = 1.0;
        ++count;
      }
    }
    if (count > 0 && count < x.size()) columns.push_back(std::move(column));
  }
  return columns;
}

// Residual sum of squares of y on X (QR with column pivoting) and X's rank.
std::pair<double, Eigen::Index> LeastSquares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y,
                                             Eigen::VectorXd* fitted = nullptr) {
  if (X.cols() == 0) {
    if (fitted) *fitted = Eigen::VectorXd::Zero(y.size());
    return {y.squaredNorm(), 0};
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
  qr.setThreshold(1e-10);
  const Eigen::VectorXd beta = qr.solve(y);
  const Eigen::VectorXd f = X * beta;
  if (fitted) *fitted = f;
  return {(y - f).squaredNorm(), qr.rank()};
}

// Filters the rows of every segment with e_t = x_t - a_1 x_{t-1} - ... (dropping each
// segment's first p rows).
Eigen::MatrixXd Whiten(const Eigen::MatrixXd& M, const std::vector<std::size_t>& segments,
                       const std::vector<double>& a) {
  const std::size_t p = a.size();
  const auto rows = static_cast<std::size_t>(M.rows());
  std::size_t kept = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t end = s + 1 < segments.size() ? segments[s + 1] : rows;
    if (end - segments[s] > p) kept += end - segments[s] - p;
  }
  Eigen::MatrixXd out(static_cast<Eigen::Index>(kept), M.cols());
  Eigen::Index at = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t end = s + 1 < segments.size() ? segments[s + 1] : rows;
    for (std::size_t r = segments[s] + p; r < end; ++r) {
      out.row(at) = M.row(static_cast<Eigen::Index>(r));
      for (std::size_t j = 0; j < p; ++j) {
        out.row(at) -= a[j] * M.row(static_cast<Eigen::Index>(r - j - 1));
      }
      ++at;
    }
  }
  return out;
}

double FSurvival(double f, double q, double dof) {
  if (!(f > 0.0) || !(q > 0.0) || !(dof > 0.0)) return 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f(q, dof), f));
}

// Legendre polynomials P1..P_degree of x in [-1, 1].
std::vector<double> Legendre(double x, int degree) {
  std::vector<double> p(static_cast<std::size_t>(degree) + 1, 0.0);
  p[0] = 1.0;
  if (degree >= 1) p[1] = x;
  for (int n = 1; n < degree; ++n) {
    p[static_cast<std::size_t>(n) + 1] = ((2.0 * n + 1.0) * x * p[static_cast<std::size_t>(n)] -
                                          n * p[static_cast<std::size_t>(n) - 1]) /
                                         (n + 1.0);
  }
  return p;
}

// Hann-windowed periodogram of each segment of x, summed onto a common grid of frequencies
// f_j = j df (j = 0..bins-1): each segment's own bin nearest to f_j.
std::vector<double> Periodogram(const std::vector<double>& x,
                                const std::vector<std::size_t>& segments,
                                const std::vector<double>& dt, double df, std::size_t bins) {
  std::vector<double> power(bins, 0.0);
  Eigen::FFT<double> fft;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const std::size_t begin = segments[s];
    const std::size_t end = s + 1 < segments.size() ? segments[s + 1] : x.size();
    const std::size_t n = end - begin;
    if (n < 8 || !(dt[s] > 0.0)) continue;
    double mean = 0.0;
    for (std::size_t r = begin; r < end; ++r) mean += x[r];
    mean /= static_cast<double>(n);
    std::size_t padded = 1;
    while (padded < 2 * n) padded *= 2;
    std::vector<double> in(padded, 0.0);
    for (std::size_t r = 0; r < n; ++r) {
      const double hann =
          0.5 - 0.5 * std::cos(2.0 * kPi * static_cast<double>(r) / static_cast<double>(n - 1));
      in[r] = hann * (x[begin + r] - mean);
    }
    std::vector<std::complex<double>> out;
    fft.fwd(out, in);
    const double own_df = 1.0 / (static_cast<double>(padded) * dt[s]);
    for (std::size_t j = 0; j < bins; ++j) {
      const auto bin = static_cast<std::size_t>(std::lround(static_cast<double>(j) * df / own_df));
      if (bin < padded / 2) power[j] += std::norm(out[bin]);
    }
  }
  return power;
}

// The fall of the sum of squares of y over rows [begin, end) that the least-squares
// a sin(x_r) + b cos(x_r) achieves, x_r = phase(r); negative when the two are collinear.
template <typename Phase>
double SinCosReduction(const std::vector<double>& y, std::size_t begin, std::size_t end,
                       Phase phase) {
  double ys = 0.0, yc = 0.0, ss = 0.0, cc = 0.0, sc = 0.0;
  for (std::size_t r = begin; r < end; ++r) {
    const double x = phase(r);
    const double si = std::sin(x), co = std::cos(x);
    ys += y[r] * si;
    yc += y[r] * co;
    ss += si * si;
    cc += co * co;
    sc += si * co;
  }
  const double det = ss * cc - sc * sc;
  if (!(det > 1e-12 * ss * cc)) return -1.0;
  return (cc * ys * ys - 2.0 * sc * ys * yc + ss * yc * yc) / det;
}

// The residual of column c in 20 bins of the test's state (periodic: of the phase).
void BinResidual(const Pooled& pooled, std::size_t c, StructureTest* test) {
  if (test->state == "u (past)") {  // the correlation at each lag, as resid draws it
    const InputPastTest& past = pooled.past[c];
    const double dt_ms = 1e3 * pooled.dt.front();
    for (std::size_t j = 0; j < past.ccf.size(); ++j) {
      test->bin_x.push_back(static_cast<double>(j + 1) * dt_ms);
      test->bin_mean.push_back(past.ccf[j]);
    }
    test->x_label = "lag of u";
    test->x_unit = "ms";
    test->band95 = past.band95;
    return;
  }
  const std::size_t n = pooled.t.size();
  std::vector<double> x(n);
  if (test->state == "theta") {
    x = pooled.theta;
    test->x_label = "theta";
    test->x_unit = "rad";
  } else if (test->state == "w" || test->state == "sign(w)") {
    x = pooled.w;
    test->x_label = "w";
    test->x_unit = "rad/s";
  } else if (test->state == "u") {
    x = pooled.u;
    test->x_label = "u";
  } else if (test->state == "t" || test->state == "mean") {
    x = pooled.t;
    test->x_label = "t";
    test->x_unit = "s";
  } else if (test->state == "t (periodic)") {
    for (std::size_t r = 0; r < n; ++r) {
      const double cycles = pooled.t[r] * test->frequency_hz;
      x[r] = cycles - std::floor(cycles);
    }
    test->x_label = "phase of t at " + G(test->frequency_hz) + " Hz";
    test->x_unit = "periods";
  } else {
    const double m = test->order;
    for (std::size_t r = 0; r < n; ++r) {
      const double cycles = m * pooled.theta[r] / (2.0 * kPi);
      x[r] = cycles - std::floor(cycles);
    }
    test->x_label = "phase of theta at " + std::to_string(test->order) + "/rev";
    test->x_unit = "periods";
  }
  const auto [lo_it, hi_it] = std::minmax_element(x.begin(), x.end());
  const double lo = *lo_it, hi = *hi_it;
  constexpr int kBins = 20;
  std::vector<double> sum(kBins, 0.0);
  std::vector<int> count(kBins, 0);
  for (std::size_t r = 0; r < n; ++r) {
    const int b =
        hi > lo ? std::min(kBins - 1, static_cast<int>((x[r] - lo) / (hi - lo) * kBins)) : 0;
    sum[static_cast<std::size_t>(b)] += pooled.residual[c][r];
    ++count[static_cast<std::size_t>(b)];
  }
  for (int b = 0; b < kBins; ++b) {
    if (count[static_cast<std::size_t>(b)] == 0) continue;
    test->bin_x.push_back(lo + (b + 0.5) * (hi - lo) / kBins);
    test->bin_mean.push_back(sum[static_cast<std::size_t>(b)] / count[static_cast<std::size_t>(b)]);
    test->bin_count.push_back(count[static_cast<std::size_t>(b)]);
  }
}

struct Basis {
  std::string state;
  std::vector<std::vector<double>> columns;
  double alternatives = 1.0;  // Bonferroni factor of a searched basis
  double frequency_hz = 0.0;
  int order = 0;
  int input_harmonic = 0;
};

}  // namespace

namespace {

// An n-row matrix whose first columns are each segment's intercept (1 on its rows) followed by
// `extra` zero columns for the caller to fill.
Eigen::MatrixXd SegmentIntercepts(Eigen::Index n, const std::vector<std::size_t>& segments,
                                  Eigen::Index extra) {
  const auto K = static_cast<Eigen::Index>(segments.size());
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, K + extra);
  for (Eigen::Index s = 0; s < K; ++s) {
    const auto begin = static_cast<Eigen::Index>(segments[static_cast<std::size_t>(s)]);
    const Eigen::Index end =
        s + 1 < K ? static_cast<Eigen::Index>(segments[static_cast<std::size_t>(s) + 1]) : n;
    X.block(begin, s, end - begin, 1).setOnes();
  }
  return X;
}

}  // namespace

FglsTest FglsFTest(const std::vector<double>& response,
                   const std::vector<std::vector<double>>& regressors,
                   const std::vector<std::size_t>& segments, int ar_max_order) {
  FglsTest out;
  const auto n = static_cast<Eigen::Index>(response.size());
  const auto K = static_cast<Eigen::Index>(segments.size());
  const auto q = static_cast<Eigen::Index>(regressors.size());
  if (n < 8 || K == 0 || q == 0) return out;
  Eigen::MatrixXd X = SegmentIntercepts(n, segments, q);
  for (Eigen::Index j = 0; j < q; ++j) {
    X.col(K + j) =
        Eigen::Map<const Eigen::VectorXd>(regressors[static_cast<std::size_t>(j)].data(), n);
  }
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(response.data(), n);
  // OLS: the share of the residual's variance (about its per-trace means) the basis explains.
  Eigen::VectorXd fitted;
  const double sse_null = LeastSquares(X.leftCols(K), y).first;
  const double sse_ols = LeastSquares(X, y, &fitted).first;
  if (!(sse_null > 0.0) || !std::isfinite(sse_null)) return out;
  out.share = std::clamp(1.0 - sse_ols / sse_null, 0.0, 1.0);
  // The noise model from the alternative's residual, then the F test on the filtered data.
  const Eigen::VectorXd e = y - fitted;
  const std::vector<double> a =
      FitAutoregression(std::vector<double>(e.data(), e.data() + e.size()), ar_max_order);
  out.ar_order = static_cast<int>(a.size());
  Eigen::MatrixXd Xy(n, K + q + 1);
  Xy << X, y;
  const Eigen::MatrixXd W = Whiten(Xy, segments, a);
  const Eigen::VectorXd yw = W.col(K + q);
  const auto [sse0, rank0] = LeastSquares(W.leftCols(K), yw);
  const auto [sse1, rank1] = LeastSquares(W.leftCols(K + q), yw);
  const double extra = static_cast<double>(rank1 - rank0);
  const double dof = static_cast<double>(W.rows() - rank1);
  if (!(extra > 0.0) || !(dof > 0.0) || !(sse1 > 0.0)) return out;
  out.f = std::max(0.0, (sse0 - sse1) / extra / (sse1 / dof));
  out.p_value = FSurvival(out.f, extra, dof);
  out.ok = std::isfinite(out.f) && std::isfinite(out.p_value);
  return out;
}

FglsTest FglsMeanTest(const std::vector<double>& response, const std::vector<std::size_t>& segments,
                      int ar_max_order) {
  FglsTest out;
  const auto n = static_cast<Eigen::Index>(response.size());
  const auto K = static_cast<Eigen::Index>(segments.size());
  if (n < 8 || K == 0) return out;
  Eigen::MatrixXd Xy = SegmentIntercepts(n, segments, 1);
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(response.data(), n);
  Xy.col(K) = y;
  // OLS: the share of the residual's mean square that its per-trace means make up.
  Eigen::VectorXd fitted;
  const double total = y.squaredNorm();
  const double sse_means = LeastSquares(Xy.leftCols(K), y, &fitted).first;
  if (!(total > 0.0) || !std::isfinite(total)) return out;
  out.share = std::clamp(1.0 - sse_means / total, 0.0, 1.0);
  const Eigen::VectorXd e = y - fitted;
  const std::vector<double> a =
      FitAutoregression(std::vector<double>(e.data(), e.data() + e.size()), ar_max_order);
  out.ar_order = static_cast<int>(a.size());
  const Eigen::MatrixXd W = Whiten(Xy, segments, a);
  const Eigen::VectorXd yw = W.col(K);
  const double sse0 = yw.squaredNorm();
  const auto [sse1, rank1] = LeastSquares(W.leftCols(K), yw);
  const double dof = static_cast<double>(W.rows() - rank1);
  if (!(rank1 > 0) || !(dof > 0.0) || !(sse1 > 0.0)) return out;
  out.f = std::max(0.0, (sse0 - sse1) / static_cast<double>(rank1) / (sse1 / dof));
  out.p_value = FSurvival(out.f, static_cast<double>(rank1), dof);
  out.ok = std::isfinite(out.f) && std::isfinite(out.p_value);
  return out;
}

std::string StructureTest::Describe() const {
  if (state == "t (periodic)") {
    return "t (periodic, " + G(frequency_hz) + " Hz" +
           (input_harmonic > 0 ? ", harmonic " + std::to_string(input_harmonic) + " of the input"
                               : std::string()) +
           ")";
  }
  if (state == "theta (periodic)") return "theta (periodic, " + std::to_string(order) + "/rev)";
  if (state == "u (past)" && frequency_hz > 0.0)
    return "u (past, largest at " + G(frequency_hz) + " Hz)";
  return state;
}

std::string AdequacyReport::StructureMessage() const {
  if (flagged.empty()) return "";
  const StructureTest& top = flagged.front();
  // Two significant digits, without an exponent at 100 %.
  const double percent = 100.0 * top.share;
  const std::string share = percent >= 99.5 ? "100" : G(percent, 2);
  std::string text = "residual depends on " + top.Describe() + " (" + top.column + ": " + share +
                     " % of its variance, p = " + G(top.p_value, 2) + ")";
  std::vector<std::string> others;
  for (std::size_t k = 1; k < flagged.size(); ++k) {
    const std::string name = flagged[k].Describe();
    if (name != top.Describe() && std::find(others.begin(), others.end(), name) == others.end())
      others.push_back(name);
  }
  if (!others.empty()) {
    text += "; also on ";
    for (std::size_t k = 0; k < others.size(); ++k) text += (k ? ", " : "") + others[k];
  }
  return text;
}

namespace {

// One past the last row of trace `s` in the pooled rows.
std::size_t SegmentEnd(const Pooled& pooled, std::size_t s) {
  return s + 1 < pooled.segments.size() ? pooled.segments[s + 1] : pooled.t.size();
}

// The state bases that do not depend on the column: the angle (linear, sin, cos), the speed
// (quantile bins) and its sign, the input (quantile bins), and each trace's time (Legendre).
std::vector<Basis> StateBases(const Pooled& pooled, const AdequacyOptions& options) {
  const std::size_t n = pooled.t.size();
  std::vector<Basis> bases;
  if (pooled.has_theta) {
    double lo = pooled.theta.front(), hi = lo;
    for (double v : pooled.theta) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    if (hi - lo > 1e-9) {
      Basis theta{"theta", {}, 1.0, 0.0, 0};
      std::vector<double> linear(n), s(n), c(n);
      for (std::size_t r = 0; r < n; ++r) {
        linear[r] = (pooled.theta[r] - 0.5 * (lo + hi)) / (0.5 * (hi - lo));
        s[r] = std::sin(pooled.theta[r]);
        c[r] = std::cos(pooled.theta[r]);
      }
      theta.columns = {linear, s, c};
      bases.push_back(std::move(theta));
    }
  }
  if (pooled.has_w) {
    Basis w{"w", QuantileBins(pooled.w, options.bins), 1.0, 0.0, 0};
    if (!w.columns.empty()) bases.push_back(std::move(w));
    std::vector<double> sign(n);
    bool positive = false, negative = false;
    for (std::size_t r = 0; r < n; ++r) {
      sign[r] = pooled.w[r] > 0.0 ? 1.0 : (pooled.w[r] < 0.0 ? -1.0 : 0.0);
      positive = positive || sign[r] > 0.0;
      negative = negative || sign[r] < 0.0;
    }
    if (positive && negative) bases.push_back({"sign(w)", {sign}, 1.0, 0.0, 0});
  }
  {
    Basis u{"u", QuantileBins(pooled.u, options.bins), 1.0, 0.0, 0};
    if (!u.columns.empty()) bases.push_back(std::move(u));
  }
  Basis t{"t", {}, 1.0, 0.0, 0};
  for (std::size_t s = 0; s < pooled.segments.size(); ++s) {
    const std::size_t begin = pooled.segments[s], end = SegmentEnd(pooled, s);
    const double t0 = pooled.t[begin], t1 = pooled.t[end - 1];
    std::vector<std::vector<double>> columns(static_cast<std::size_t>(options.legendre_degree),
                                             std::vector<double>(n, 0.0));
    for (std::size_t r = begin; r < end; ++r) {
      const double x = t1 > t0 ? 2.0 * (pooled.t[r] - t0) / (t1 - t0) - 1.0 : 0.0;
      const std::vector<double> p = Legendre(x, options.legendre_degree);
      for (std::size_t d = 1; d < p.size(); ++d) columns[d - 1][r] = p[d];
    }
    for (auto& column : columns) t.columns.push_back(std::move(column));
  }
  bases.push_back(std::move(t));
  return bases;
}

// The frequencies the t (periodic) test searches: from two periods over the longest trace up
// to the Nyquist frequency (or max_frequency_hz), on the grid of the longest trace's two-fold
// zero-padded FFT. The input's strongest line is kept to say when the residual's period is a
// harmonic of the input's (a dynamic misfit repeats with the input).
struct FrequencyGrid {
  std::vector<std::size_t> allowed;  // bins searched; empty: no periodic test
  double df = 0.0;                   // Hz per bin
  double input_hz = 0.0;             // the input's strongest line, 0 when none
};

FrequencyGrid TimeFrequencyGrid(const Pooled& pooled, const AdequacyOptions& options) {
  double longest = 0.0, finest_dt = std::numeric_limits<double>::infinity();
  for (std::size_t s = 0; s < pooled.segments.size(); ++s) {
    longest = std::max(longest, pooled.t[SegmentEnd(pooled, s) - 1] - pooled.t[pooled.segments[s]]);
    finest_dt = std::min(finest_dt, pooled.dt[s]);
  }
  FrequencyGrid grid;
  if (!(longest > 0.0 && finest_dt > 0.0)) return grid;
  grid.df = 0.5 / longest;  // the grid of a two-fold zero-padded FFT
  double top = 0.5 / finest_dt;
  if (options.max_frequency_hz > 0.0) top = std::min(top, options.max_frequency_hz);
  const auto bins = static_cast<std::size_t>(top / grid.df);
  const std::vector<double> input =
      Periodogram(pooled.u, pooled.segments, pooled.dt, grid.df, bins);
  std::size_t strongest = 0;
  for (std::size_t j = 1; j < bins; ++j) {
    if (input[j] > input[strongest]) strongest = j;
  }
  if (strongest > 0 && input[strongest] > 0.0)
    grid.input_hz = static_cast<double>(strongest) * grid.df;
  for (std::size_t j = static_cast<std::size_t>(std::ceil(2.0 / longest / grid.df)); j < bins; ++j)
    grid.allowed.push_back(j);
  return grid;
}

// `y` about each trace's mean, what the periodic searches fit.
std::vector<double> CentredPerTrace(const Pooled& pooled, const std::vector<double>& y) {
  std::vector<double> centred(y.size());
  for (std::size_t s = 0; s < pooled.segments.size(); ++s) {
    const std::size_t begin = pooled.segments[s], end = SegmentEnd(pooled, s);
    double mean = 0.0;
    for (std::size_t r = begin; r < end; ++r) mean += y[r];
    mean /= static_cast<double>(end - begin);
    for (std::size_t r = begin; r < end; ++r) centred[r] = y[r] - mean;
  }
  return centred;
}

// theta (periodic): the order whose sin/cos explain most of the residual (about each trace's
// mean), among those completing at least three periods over the angle travelled. None when no
// order qualifies.
std::optional<Basis> AngleHarmonicBasis(const Pooled& pooled, const std::vector<double>& centred,
                                        const AdequacyOptions& options) {
  const std::size_t n = pooled.t.size();
  double travelled = 0.0;
  for (std::size_t s = 0; s < pooled.segments.size(); ++s) {
    for (std::size_t r = pooled.segments[s] + 1; r < SegmentEnd(pooled, s); ++r)
      travelled += std::abs(pooled.theta[r] - pooled.theta[r - 1]);
  }
  // (in double first: a shaft that hardly turns would overflow the int)
  const double fewest = std::ceil(3.0 * 2.0 * kPi / std::max(travelled, 1e-300));
  const int lowest =
      fewest > options.max_order ? options.max_order + 1 : std::max(2, static_cast<int>(fewest));
  int best_order = 0;
  double best_reduction = 0.0;
  int searched = 0;
  for (int m = lowest; m <= options.max_order; ++m) {
    const double reduction =
        SinCosReduction(centred, 0, n, [&](std::size_t r) { return m * pooled.theta[r]; });
    if (reduction < 0.0) continue;
    ++searched;
    if (reduction > best_reduction) {
      best_reduction = reduction;
      best_order = m;
    }
  }
  if (best_order == 0) return std::nullopt;
  std::vector<double> s(n), co(n);
  for (std::size_t r = 0; r < n; ++r) {
    s[r] = std::sin(best_order * pooled.theta[r]);
    co[r] = std::cos(best_order * pooled.theta[r]);
  }
  return Basis{"theta (periodic)", {s, co}, static_cast<double>(searched), 0.0, best_order};
}

// t (periodic): the periodogram's highest allowed bin, refined, as a sin/cos pair per trace.
Basis TimeHarmonicBasis(const Pooled& pooled, const std::vector<double>& y,
                        const std::vector<double>& centred, const FrequencyGrid& grid) {
  const std::size_t n = pooled.t.size();
  const std::size_t traces = pooled.segments.size();
  const std::vector<double> power =
      Periodogram(y, pooled.segments, pooled.dt, grid.df, grid.allowed.back() + 1);
  std::size_t best = grid.allowed.front();
  for (std::size_t j : grid.allowed) {
    if (power[j] > power[best]) best = j;
  }
  // The grid is coarse against the Hann main lobe: refine the frequency to the one whose
  // sinusoid (per trace, about each trace's mean) explains most, within two bins.
  double f = static_cast<double>(best) * grid.df, best_reduction = -1.0;
  for (int step = -40; step <= 40; ++step) {
    const double trial = (static_cast<double>(best) + step / 20.0) * grid.df;
    if (!(trial > 0.0)) continue;
    double reduction = 0.0;
    for (std::size_t s = 0; s < traces; ++s) {
      reduction += std::max(
          0.0, SinCosReduction(centred, pooled.segments[s], SegmentEnd(pooled, s),
                               [&](std::size_t r) { return 2.0 * kPi * trial * pooled.t[r]; }));
    }
    if (reduction > best_reduction) {
      best_reduction = reduction;
      f = trial;
    }
  }
  Basis periodic{"t (periodic)", {}, 1.0, f, 0};
  if (grid.input_hz > 0.0) {
    const double harmonic = std::round(f / grid.input_hz);
    if (harmonic >= 1.0 && std::abs(f - harmonic * grid.input_hz) <= grid.df)
      periodic.input_harmonic = static_cast<int>(harmonic);
  }
  for (std::size_t s = 0; s < traces; ++s) {
    std::vector<double> sine(n, 0.0), cosine(n, 0.0);
    for (std::size_t r = pooled.segments[s]; r < SegmentEnd(pooled, s); ++r) {
      sine[r] = std::sin(2.0 * kPi * f * pooled.t[r]);
      cosine[r] = std::cos(2.0 * kPi * f * pooled.t[r]);
    }
    periodic.columns.push_back(std::move(sine));
    periodic.columns.push_back(std::move(cosine));
  }
  // The zero-padded grid is twice as fine as the independent frequencies.
  periodic.alternatives = std::max(1.0, 0.5 * static_cast<double>(grid.allowed.size()));
  return periodic;
}

// The delay by which the measured `column` lags the simulated one, when a delay explains the
// residual that follows the input: measured(t) = simulated(t - tau) ~ simulated(t) - tau
// simulated'(t), so the residual is regressed on the simulated derivative (central
// differences, per trace, with an intercept per trace); tau = -slope. A delay is named when
// tau > 0 and the regression explains at least half of what the input's past explains
// (`past_share`); 0 otherwise, and for columns other than w and theta.
double MeasurementLag(const Pooled& pooled, const std::string& column,
                      const std::vector<double>& residual, double past_share) {
  const std::vector<double>* state = column == "w" && pooled.has_w           ? &pooled.w
                                     : column == "theta" && pooled.has_theta ? &pooled.theta
                                                                             : nullptr;
  if (!state || !(past_share > 0.0)) return 0.0;
  const std::size_t n = residual.size();
  std::vector<double> derivative(n, 0.0);
  for (std::size_t s = 0; s < pooled.segments.size(); ++s) {
    const std::size_t first = pooled.segments[s], last = SegmentEnd(pooled, s);
    const double dt = pooled.dt[s];
    for (std::size_t k = first + 1; k + 1 < last && dt > 0.0; ++k)
      derivative[k] = ((*state)[k + 1] - (*state)[k - 1]) / (2.0 * dt);
  }
  const Eigen::Index rows = static_cast<Eigen::Index>(n);
  Eigen::MatrixXd X = SegmentIntercepts(rows, pooled.segments, 1);
  const Eigen::Index slope = X.cols() - 1;
  for (Eigen::Index r = 0; r < rows; ++r) X(r, slope) = derivative[static_cast<std::size_t>(r)];
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(residual.data(), rows);
  const Eigen::VectorXd beta = X.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd means =
      X.leftCols(slope) * X.leftCols(slope).colPivHouseholderQr().solve(y);
  const double sse0 = (y - means).squaredNorm(), sse1 = (y - X * beta).squaredNorm();
  if (!(sse0 > 0.0) || !std::isfinite(beta(slope))) return 0.0;
  const double share = 1.0 - sse1 / sse0;
  const double tau = -beta(slope);
  return tau > 0.0 && share >= 0.5 * past_share ? tau : 0.0;
}

// Every test of column `c` appended to report->tests: the mean, then each basis.
void TestColumn(const Pooled& pooled, std::size_t c, const std::string& column,
                const std::vector<Basis>& bases, const FrequencyGrid& grid,
                const AdequacyOptions& options, AdequacyReport* report) {
  const std::vector<double>& y = pooled.residual[c];
  // mean: the residual's own level, each trace's, against zero (an offset, a constant torque
  // the fit could not take up); every other basis has the means in its null model.
  if (options.test_mean) {
    const FglsTest test = FglsMeanTest(y, pooled.segments, options.ar_max_order);
    if (test.ok) {
      StructureTest out;
      out.state = "mean";
      out.column = column;
      out.regressors = static_cast<int>(pooled.segments.size());
      out.f = test.f;
      out.p_value = test.p_value;
      out.share = test.share;
      out.ar_order = test.ar_order;
      report->tests.push_back(out);
    }
  }
  std::vector<Basis> column_bases = bases;
  const std::vector<double> centred = CentredPerTrace(pooled, y);
  if (pooled.has_theta) {
    std::optional<Basis> angle = AngleHarmonicBasis(pooled, centred, options);
    if (angle) column_bases.push_back(std::move(*angle));
  }
  if (!grid.allowed.empty()) column_bases.push_back(TimeHarmonicBasis(pooled, y, centred, grid));
  for (const Basis& basis : column_bases) {
    const FglsTest test = FglsFTest(y, basis.columns, pooled.segments, options.ar_max_order);
    if (!test.ok) continue;
    StructureTest out;
    out.state = basis.state;
    out.column = column;
    out.regressors = static_cast<int>(basis.columns.size());
    out.f = test.f;
    out.p_value = std::min(1.0, test.p_value * basis.alternatives);  // the search's factor
    out.share = test.share;
    out.ar_order = test.ar_order;
    out.frequency_hz = basis.frequency_hz;
    out.order = basis.order;
    out.input_harmonic = basis.input_harmonic;
    report->tests.push_back(out);
  }
  if (pooled.input_past && c < pooled.past.size() && pooled.past[c].ok) {
    const InputPastTest& past = pooled.past[c];
    StructureTest out;
    out.state = "u (past)";
    out.column = column;
    out.regressors = past.lags;
    out.f = past.statistic / past.lags;
    out.p_value = past.p_value;
    out.share = past.share;
    out.ar_order = past.ar_order;
    out.frequency_hz = past.frequency_hz;
    out.lags = past.lags;
    out.lag_s = MeasurementLag(pooled, column, y, past.share);
    report->tests.push_back(out);
  }
}

// The family's verdict: every test's p-value times the number of tests run, flagged when
// significant and material; the mean named only when nothing else explains its column (a
// residual that follows the angle or the time has a mean too, and the state is the better
// name); the flagged tests binned for the plot, largest share first.
void FlagStructure(const Pooled& pooled, const std::vector<std::string>& observe,
                   const AdequacyOptions& options, AdequacyReport* report) {
  const double tests_run = static_cast<double>(report->tests.size());
  for (StructureTest& test : report->tests) {
    test.p_value = std::min(1.0, test.p_value * tests_run);
    test.significant = test.p_value < options.family_level;
    test.flagged = test.significant && test.share >= options.min_share;
  }
  for (StructureTest& test : report->tests) {
    if (test.state != "mean" || !test.flagged) continue;
    for (const StructureTest& other : report->tests) {
      if (other.column == test.column && other.state != "mean" && other.flagged)
        test.flagged = false;
    }
  }
  for (StructureTest& test : report->tests) {
    if (!test.flagged) continue;
    const auto c = static_cast<std::size_t>(std::find(observe.begin(), observe.end(), test.column) -
                                            observe.begin());
    BinResidual(pooled, c, &test);
    report->flagged.push_back(test);
  }
  std::stable_sort(
      report->flagged.begin(), report->flagged.end(),
      [](const StructureTest& a, const StructureTest& b) { return a.share > b.share; });
}

}  // namespace

AdequacyReport CheckResidualStructure(const FitProblem& problem, const std::vector<double>& values,
                                      const AdequacyOptions& options) {
  AdequacyReport report;
  report.family_level = options.family_level;
  report.min_share = options.min_share;
  Pooled pooled;
  if (!Gather(problem, values, &pooled, &report.reason)) return report;
  pooled.input_past =
      options.input_lags > 0 && !problem.equation_error() && problem.measured(0).Has("u");
  if (pooled.input_past) {
    // One rate for the response's frequency axis: the traces' own, when they agree to 1 %.
    const auto [dt_lo, dt_hi] = std::minmax_element(pooled.dt.begin(), pooled.dt.end());
    const double rate = *dt_lo > 0.0 && *dt_hi <= 1.01 * *dt_lo ? 1.0 / *dt_hi : 0.0;
    for (const auto& residual : pooled.residual)
      pooled.past.push_back(
          TestInputPast(residual, pooled.u, pooled.segments, rate, options.input_lags));
  }
  const std::vector<Basis> bases = StateBases(pooled, options);
  const FrequencyGrid grid = TimeFrequencyGrid(pooled, options);
  for (std::size_t c = 0; c < problem.observe().size(); ++c)
    TestColumn(pooled, c, problem.observe()[c], bases, grid, options, &report);
  FlagStructure(pooled, problem.observe(), options, &report);
  report.ok = true;
  return report;
}

void CheckEffectStability(const FitProblem& problem, const std::vector<double>& values,
                          const std::vector<std::string>& effects, const OptimizerOptions& refit,
                          const AdequacyOptions& options, AdequacyReport* report) {
  report->stability.clear();
  report->unstable.clear();
  // The effect parameters to compare: free, not periodic (a phase wraps), of an effect whose
  // states the record's initial conditions give (a part cut from the middle starts a hidden
  // state such as a two-mass shaft's twist wrong, and its transient moves the part's fit).
  std::vector<std::size_t> compared;
  std::vector<std::string> owner;
  std::string hidden;
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    std::string effect;
    const std::string& name = problem.free()[k].name;
    if (!IsEffectParameter(name, &effect)) continue;
    if (std::find(effects.begin(), effects.end(), effect) == effects.end()) continue;
    if (IsPeriodicParameter(name)) continue;
    if (FindEffect(effect).hidden_states) {
      if (hidden.find(effect) == std::string::npos) hidden += (hidden.empty() ? "" : ", ") + effect;
      continue;
    }
    compared.push_back(k);
    owner.push_back(effect);
  }
  if (compared.empty()) {
    report->stability_reason = hidden.empty()
                                   ? "no effect parameter to compare"
                                   : "no effect parameter to compare (" + hidden +
                                         ": its hidden states at a part's start are unknown)";
    return;
  }
  const internal::RecordParts parts = internal::SplitRecord(problem, values);
  if (!parts.ok) {
    report->stability_reason = parts.reason;
    return;
  }
  report->parts = parts.description;
  std::vector<FitResult> fits;
  for (const auto* part : {&parts.first, &parts.second}) {
    std::vector<FreeParameter> free = problem.free();
    for (std::size_t k = 0; k < free.size(); ++k)
      free[k].initial = std::clamp(values[k], free[k].lower, free[k].upper);
    const FitProblem part_problem(problem.config(), *part, problem.observe(), free);
    OptimizerOptions fit_options = refit;
    fit_options.method_options = nlohmann::json::object();
    fit_options.method_options["max_iterations"] = 30;
    fits.push_back(FindOptimizer("ceres").Minimize(part_problem, fit_options));
    if (!fits.back().evaluation.ok) {
      report->stability_reason =
          "a part of the record could not be refit: " + fits.back().evaluation.reason;
      return;
    }
  }
  const double tail = options.family_level / (2.0 * static_cast<double>(compared.size()));
  const double limit = boost::math::quantile(boost::math::complement(boost::math::normal(), tail));
  for (std::size_t j = 0; j < compared.size(); ++j) {
    const std::size_t k = compared[j];
    EffectStability s;
    s.effect = owner[j];
    s.parameter = problem.free()[k].name;
    s.first = fits[0].values[k];
    s.second = fits[1].values[k];
    const ParameterEstimate& a = fits[0].estimates[k];
    const ParameterEstimate& b = fits[1].estimates[k];
    s.first_std = a.has_interval ? a.std : 0.0;
    s.second_std = b.has_interval ? b.std : 0.0;
    const double spread = std::hypot(s.first_std, s.second_std);
    s.limit = limit;
    s.z = spread > 0.0 ? std::abs(s.first - s.second) / spread
                       : std::numeric_limits<double>::infinity();
    const double scale = std::max(std::abs(values[k]), 1e-300);
    // An estimate within two of its standard errors of its search bound has no normal
    // interval (the bound truncates its distribution: Self & Liang, J. Amer. Statist. Assoc.
    // 82, 1987): a part that does not excite what the parameter describes (a chirp's half
    // below a resonance) leaves it there, which says nothing about a change over the record.
    const FreeParameter& free = problem.free()[k];
    auto near_bound = [&](double value, double std) {
      return value - free.lower <= 2.0 * std || free.upper - value <= 2.0 * std;
    };
    s.near_bound = near_bound(s.first, s.first_std) || near_bound(s.second, s.second_std);
    s.unstable = !s.near_bound && s.z > limit &&
                 std::abs(s.first - s.second) > options.min_relative_change * scale;
    if (s.unstable && std::find(report->unstable.begin(), report->unstable.end(), s.effect) ==
                          report->unstable.end())
      report->unstable.push_back(s.effect);
    report->stability.push_back(s);
  }
  report->stability_checked = true;
}

}  // namespace blmd
