#include "blmd/ident/uncertainty/uncertainty.h"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>

namespace blmd {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Andrews & Monahan (1992) keep the prewhitening filter away from a unit root: singular
// values of A above this are set to it.
constexpr double kMaxPrewhiteningGain = 0.97;

// Andrews (1991) eq. (6.4): the AR(1) plug-in bandwidth of the Bartlett kernel from each
// score component's AR(1) coefficient rho_a and innovation variance s2_a (equal weights).
double AndrewsBartlettBandwidth(const std::vector<MatrixXd>& series, double length) {
  const Index p = series.empty() ? 0 : series.front().cols();
  double numerator = 0.0, denominator = 0.0;
  for (Index a = 0; a < p; ++a) {
    double xy = 0.0, xx = 0.0;
    for (const MatrixXd& h : series) {
      for (Index t = 1; t < h.rows(); ++t) {
        xy += h(t, a) * h(t - 1, a);
        xx += h(t - 1, a) * h(t - 1, a);
      }
    }
    if (!(xx > 0.0)) continue;
    const double rho = std::clamp(xy / xx, -0.97, 0.97);
    double ss = 0.0;
    double count = 0.0;
    for (const MatrixXd& h : series) {
      for (Index t = 1; t < h.rows(); ++t) {
        const double innovation = h(t, a) - rho * h(t - 1, a);
        ss += innovation * innovation;
        count += 1.0;
      }
    }
    const double s2 = count > 0.0 ? ss / count : 0.0;
    const double s4 = s2 * s2;
    numerator += 4.0 * rho * rho * s4 / (std::pow(1.0 - rho, 6) * std::pow(1.0 + rho, 2));
    denominator += s4 / std::pow(1.0 - rho, 4);
  }
  if (!(denominator > 0.0)) return 0.0;
  const double alpha = numerator / denominator;
  return 1.1447 * std::cbrt(alpha * length);
}

}  // namespace

double StudentTQuantile975(double degrees_of_freedom) {
  if (!(degrees_of_freedom < 1e7)) {
    return boost::math::quantile(boost::math::complement(boost::math::normal(), 0.025));
  }
  return boost::math::quantile(
      boost::math::complement(boost::math::students_t(std::max(degrees_of_freedom, 1.0)), 0.025));
}

SandwichCovariance HacSandwichCovariance(const MatrixXd& jacobian, const VectorXd& residuals,
                                         const ResidualLayout& layout) {
  SandwichCovariance result;
  const Index n = jacobian.rows(), p = jacobian.cols();
  std::size_t expected = 0;
  for (std::size_t rows : layout.rows) expected += rows * layout.columns;
  if (p == 0 || residuals.size() != n || static_cast<std::size_t>(n) != expected) {
    result.reason = "residuals and Jacobian do not match the layout";
    return result;
  }
  if (!jacobian.allFinite() || !residuals.allFinite()) {
    result.reason = "the Jacobian or the residuals are not finite";
    return result;
  }
  // Columns scaled to unit norm: J^T J of parameters whose sensitivities differ by many
  // orders of magnitude (a load torque in N·m beside a drag in N·m·s²) is inverted in a
  // well-scaled basis, and singularity is judged there.
  VectorXd scale(p);
  for (Index j = 0; j < p; ++j) {
    const double norm = jacobian.col(j).norm();
    if (!(norm > 0.0)) {
      result.reason = "the cost does not depend on a free parameter (a zero Jacobian column)";
      return result;
    }
    scale(j) = 1.0 / norm;
  }
  const MatrixXd js = jacobian * scale.asDiagonal();
  const MatrixXd information = js.transpose() * js;
  Eigen::JacobiSVD<MatrixXd> svd(information, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const VectorXd& singular = svd.singularValues();
  if (!(singular(p - 1) >= 1e-12 * singular(0))) {
    result.reason =
        "the Jacobian is rank deficient: the free parameters are not separately "
        "identifiable from these traces";
    return result;
  }
  const MatrixXd inverse = svd.solve(MatrixXd::Identity(p, p));

  // Scores per time instant, one series per trace.
  std::vector<MatrixXd> scores;
  Index offset = 0;
  for (std::size_t rows : layout.rows) {
    const Index T = static_cast<Index>(rows);
    MatrixXd g = MatrixXd::Zero(T, p);
    for (std::size_t c = 0; c < layout.columns; ++c) {
      for (Index t = 0; t < T; ++t) {
        const Index r = offset + static_cast<Index>(c) * T + t;
        g.row(t) += residuals(r) * js.row(r);
      }
    }
    scores.push_back(std::move(g));
    offset += T * static_cast<Index>(layout.columns);
  }

  // VAR(1) prewhitening, pooled over the traces.
  MatrixXd lagged = MatrixXd::Zero(p, p), cross = MatrixXd::Zero(p, p);
  for (const MatrixXd& g : scores) {
    for (Index t = 1; t < g.rows(); ++t) {
      lagged += g.row(t - 1).transpose() * g.row(t - 1);
      cross += g.row(t).transpose() * g.row(t - 1);
    }
  }
  MatrixXd A = MatrixXd::Zero(p, p);
  Eigen::JacobiSVD<MatrixXd> lagged_svd(lagged, Eigen::ComputeFullU | Eigen::ComputeFullV);
  if (lagged_svd.singularValues()(p - 1) > 1e-12 * lagged_svd.singularValues()(0)) {
    A = lagged_svd.solve(cross.transpose()).transpose();  // A lagged = cross
    Eigen::JacobiSVD<MatrixXd> a_svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
    VectorXd gains = a_svd.singularValues();
    if (gains(0) > kMaxPrewhiteningGain) {
      for (Index j = 0; j < p; ++j) gains(j) = std::min(gains(j), kMaxPrewhiteningGain);
      A = a_svd.matrixU() * gains.asDiagonal() * a_svd.matrixV().transpose();
    }
  }
  result.max_var_eigenvalue = A.eigenvalues().cwiseAbs().maxCoeff();
  std::vector<MatrixXd> whitened;
  double total = 0.0;
  for (const MatrixXd& g : scores) {
    if (g.rows() < 2) continue;
    MatrixXd h(g.rows() - 1, p);
    for (Index t = 1; t < g.rows(); ++t) h.row(t - 1) = g.row(t) - g.row(t - 1) * A.transpose();
    total += static_cast<double>(h.rows());
    whitened.push_back(std::move(h));
  }
  if (whitened.empty()) {
    result.reason = "too few samples for the residual's correlation";
    return result;
  }
  const double mean_length = total / static_cast<double>(whitened.size());
  const double bandwidth =
      std::min(AndrewsBartlettBandwidth(whitened, mean_length), std::max(0.0, mean_length - 1.0));
  result.bandwidth = bandwidth;
  const Index lags = static_cast<Index>(std::floor(bandwidth));
  MatrixXd s_h = MatrixXd::Zero(p, p);
  for (const MatrixXd& h : whitened) {
    s_h += h.transpose() * h;
    for (Index l = 1; l <= lags && l < h.rows(); ++l) {
      const double weight = 1.0 - static_cast<double>(l) / (bandwidth + 1.0);
      const MatrixXd gamma = h.bottomRows(h.rows() - l).transpose() * h.topRows(h.rows() - l);
      s_h += weight * (gamma + gamma.transpose());
    }
  }
  // The white sandwich: samples independent, each column with its own residual variance.
  VectorXd column_variance = VectorXd::Zero(static_cast<Index>(layout.columns));
  {
    VectorXd count = VectorXd::Zero(static_cast<Index>(layout.columns));
    Index at = 0;
    for (std::size_t rows : layout.rows) {
      for (std::size_t c = 0; c < layout.columns; ++c) {
        for (std::size_t t = 0; t < rows; ++t, ++at) {
          column_variance(static_cast<Index>(c)) += residuals(at) * residuals(at);
        }
        count(static_cast<Index>(c)) += static_cast<double>(rows);
      }
    }
    column_variance = column_variance.cwiseQuotient(count.cwiseMax(1.0));
  }
  MatrixXd meat_white = MatrixXd::Zero(p, p);
  {
    Index at = 0;
    for (std::size_t rows : layout.rows) {
      for (std::size_t c = 0; c < layout.columns; ++c) {
        const auto block = js.middleRows(at, static_cast<Index>(rows));
        meat_white += column_variance(static_cast<Index>(c)) * (block.transpose() * block);
        at += static_cast<Index>(rows);
      }
    }
  }
  // Degrees of freedom of the long-run variance (Satterthwaite 1946: a variance estimate whose
  // log has variance V behaves like a chi-square with 2/V degrees of freedom). Two sources add:
  // the prewhitening filter, whose recolouring (1 - a)^-2 has Var(ln) = 4 (1 + a) /
  // (T (1 - a)) for an AR(1) coefficient a estimated from T pairs (Box & Jenkins: Var(a) =
  // (1 - a^2) / T), here with a the largest |eigenvalue| of A; and the Bartlett kernel, whose
  // estimate has Var(ln) = 4 L / (3 T) (Andrews 1991, eq. 5.2 with the kernel's integral of
  // k^2 = 2/3). With white scores it is about 3T/8 and the t quantile 1.96; with
  // a = 0.95 and T = 4000 it is about 51 (t = 2.01).
  {
    const double a = std::min(result.max_var_eigenvalue, kMaxPrewhiteningGain);
    const double v_prewhitening = 4.0 * (1.0 + a) / (total * (1.0 - a));
    const double v_kernel = 4.0 * std::max(bandwidth, 1.0) / (3.0 * total);
    result.degrees_of_freedom = std::max(1.0, 2.0 / (v_prewhitening + v_kernel));
  }
  const MatrixXd recolour = (MatrixXd::Identity(p, p) - A).inverse();
  const MatrixXd s = recolour * s_h * recolour.transpose();
  const MatrixXd covariance_scaled = inverse * s * inverse;
  result.covariance = scale.asDiagonal() * covariance_scaled * scale.asDiagonal();
  result.white = scale.asDiagonal() * (inverse * meat_white * inverse) * scale.asDiagonal();
  if (!result.covariance.allFinite()) {
    result.reason = "the covariance is not finite";
    return result;
  }
  for (Index j = 0; j < p; ++j) {
    result.variance_ratio.push_back(result.covariance(j, j) / result.white(j, j));
  }
  result.ok = true;
  return result;
}

}  // namespace blmd
