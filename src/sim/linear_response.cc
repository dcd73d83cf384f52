#include "blmd/sim/linear_response.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <unsupported/Eigen/MatrixFunctions>

namespace blmd {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where y(t) first reaches `level` (y rising towards it from below, in units of the final
// value), interpolated linearly; NaN when never.
double FirstReaching(const std::vector<double>& t, const std::vector<double>& normalised,
                     double level) {
  if (normalised.empty()) return kNaN;
  if (normalised[0] >= level) return t[0];
  for (std::size_t i = 1; i < normalised.size(); ++i) {
    if (normalised[i] >= level) {
      const double f = (level - normalised[i - 1]) / (normalised[i] - normalised[i - 1]);
      return t[i - 1] + f * (t[i] - t[i - 1]);
    }
  }
  return kNaN;
}

// The roots of a polynomial (descending powers) by the eigenvalues of its companion matrix.
Eigen::VectorXcd Roots(const std::vector<double>& p) {
  const auto n = static_cast<Eigen::Index>(p.size()) - 1;
  if (n < 1) return {};
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) companion(0, k) = -p[static_cast<std::size_t>(k) + 1] / p[0];
  for (Eigen::Index k = 1; k < n; ++k) companion(k, k - 1) = 1.0;
  return companion.eigenvalues();
}

// Output k's final value, or the reason it has none.
StepFigures FinalValue(const TransferFunction& tf) {
  StepFigures figures;
  const std::vector<double>& den = tf.denominator;
  if (den.back() == 0.0) {
    figures.reason = "integrating output (a pole at s = 0): a step gives a ramp, no final value";
    return figures;
  }
  double scale = 0.0;
  const Eigen::VectorXcd roots = Roots(den);
  for (Eigen::Index k = 0; k < roots.size(); ++k) scale = std::max(scale, std::abs(roots(k)));
  for (Eigen::Index k = 0; k < roots.size(); ++k) {
    if (!(roots(k).real() < -1e-12 * scale)) {
      figures.reason = "not stable (a pole with Re s >= 0): no final value";
      return figures;
    }
  }
  figures.ok = true;
  figures.final_value = tf.numerator.back() / den.back();
  return figures;
}

}  // namespace

void DiscretiseLinearModel(const LinearModel& model, double dt_s, Eigen::MatrixXd* phi,
                           Eigen::VectorXd* gamma) {
  const Eigen::Index n = model.A.rows();
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(n + 1, n + 1);
  augmented.topLeftCorner(n, n) = model.A * dt_s;
  augmented.topRightCorner(n, 1) = model.B * dt_s;
  const Eigen::MatrixXd expm = augmented.exp();
  *phi = expm.topLeftCorner(n, n);
  *gamma = expm.topRightCorner(n, 1);
}

namespace {

// C_k (λI - M)^-1 b + D_k.
std::complex<double> Resolvent(const LinearModel& model, std::size_t output,
                               const Eigen::MatrixXd& M, const Eigen::VectorXd& b,
                               std::complex<double> lambda) {
  const Eigen::Index n = M.rows();
  const Eigen::MatrixXcd shifted =
      lambda * Eigen::MatrixXcd::Identity(n, n) - M.cast<std::complex<double>>();
  const Eigen::VectorXcd x = shifted.partialPivLu().solve(b.cast<std::complex<double>>());
  const auto k = static_cast<Eigen::Index>(output);
  return (model.C.row(k).cast<std::complex<double>>() * x)(0) + model.D(k, 0);
}

}  // namespace

std::complex<double> FrequencyResponse(const LinearModel& model, std::size_t output, double f_hz,
                                       double sample_interval_s) {
  const double omega = 2.0 * std::numbers::pi * f_hz;
  if (!(sample_interval_s > 0.0))
    return Resolvent(model, output, model.A, model.B.col(0), {0.0, omega});
  Eigen::MatrixXd phi;
  Eigen::VectorXd gamma;
  DiscretiseLinearModel(model, sample_interval_s, &phi, &gamma);
  return Resolvent(model, output, phi, gamma, std::polar(1.0, omega * sample_interval_s));
}

BodeCurve Bode(const LinearModel& model, std::size_t output, const std::vector<double>& f_hz,
               double sample_interval_s) {
  BodeCurve curve;
  curve.f_hz = f_hz;
  const bool sampled = sample_interval_s > 0.0;
  Eigen::MatrixXd phi = model.A;
  Eigen::VectorXd gamma = model.B.col(0);
  if (sampled) DiscretiseLinearModel(model, sample_interval_s, &phi, &gamma);
  double previous = 0.0;
  for (std::size_t i = 0; i < f_hz.size(); ++i) {
    const double omega = 2.0 * std::numbers::pi * f_hz[i];
    const std::complex<double> lambda =
        sampled ? std::polar(1.0, omega * sample_interval_s) : std::complex<double>(0.0, omega);
    const std::complex<double> g = Resolvent(model, output, phi, gamma, lambda);
    curve.magnitude_db.push_back(20.0 * std::log10(std::abs(g)));
    double phase = std::arg(g) * 180.0 / std::numbers::pi;
    if (i > 0) phase -= 360.0 * std::round((phase - previous) / 360.0);
    curve.phase_deg.push_back(phase);
    previous = phase;
  }
  return curve;
}

StepFigures MeasureStep(const std::vector<double>& t_s, const std::vector<double>& y,
                        double final_value, double settling_band) {
  StepFigures figures;
  figures.final_value = final_value;
  if (!std::isfinite(final_value) || final_value == 0.0) {
    figures.reason = "the final value is zero or not finite";
    return figures;
  }
  std::vector<double> r(y.size());  // y in units of the final value
  for (std::size_t i = 0; i < y.size(); ++i) r[i] = y[i] / final_value;
  const double t10 = FirstReaching(t_s, r, 0.1), t90 = FirstReaching(t_s, r, 0.9);
  if (!std::isfinite(t10) || !std::isfinite(t90)) {
    figures.reason = "the response does not reach 90 % of its final value";
    return figures;
  }
  figures.ok = true;
  figures.rise_time_s = t90 - t10;
  const auto peak = static_cast<std::size_t>(std::max_element(r.begin(), r.end()) - r.begin());
  figures.peak_value = y[peak];
  figures.peak_time_s = t_s[peak];
  figures.overshoot_percent = std::max(0.0, 100.0 * (r[peak] - 1.0));
  // The last sample outside the band; settled from where the line between it and the next
  // enters the band.
  std::size_t last = r.size();
  for (std::size_t i = r.size(); i-- > 0;) {
    if (std::abs(r[i] - 1.0) > settling_band) {
      last = i;
      break;
    }
  }
  if (last == r.size()) {
    figures.settling_time_s = t_s.front();
  } else if (last + 1 == r.size()) {
    figures.settling_time_s = kNaN;
  } else {
    const double edge = r[last] > 1.0 ? 1.0 + settling_band : 1.0 - settling_band;
    const double f = (edge - r[last]) / (r[last + 1] - r[last]);
    figures.settling_time_s = t_s[last] + f * (t_s[last + 1] - t_s[last]);
  }
  return figures;
}

StepResponse ComputeStepResponse(const LinearModel& model) {
  StepResponse response;
  if (!model.available) {
    response.reason = model.reason.empty() ? "no linear part" : model.reason;
    return response;
  }
  const Eigen::VectorXcd eigenvalues = model.A.eigenvalues();
  double fastest = 0.0, slowest = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < eigenvalues.size(); ++k)
    fastest = std::max(fastest, std::abs(eigenvalues(k)));
  for (Eigen::Index k = 0; k < eigenvalues.size(); ++k) {
    if (eigenvalues(k).real() < -1e-9 * fastest)
      slowest = std::min(slowest, -eigenvalues(k).real());
  }
  if (!std::isfinite(slowest) || !(fastest > 0.0)) {
    response.reason = "no stable pole sets a time scale for the step response";
    return response;
  }
  response.duration_s = 8.0 / slowest;
  const double wanted = std::ceil(50.0 * response.duration_s * fastest);
  const auto steps = static_cast<std::size_t>(std::clamp(wanted, 2000.0, 200000.0));
  response.dt_s = response.duration_s / static_cast<double>(steps);
  Eigen::MatrixXd phi;
  Eigen::VectorXd gamma;
  DiscretiseLinearModel(model, response.dt_s, &phi, &gamma);
  const auto outputs = static_cast<std::size_t>(model.C.rows());
  response.y.assign(outputs, std::vector<double>(steps + 1));
  response.t_s.resize(steps + 1);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.A.rows());
  for (std::size_t i = 0; i <= steps; ++i) {
    response.t_s[i] = static_cast<double>(i) * response.dt_s;
    const Eigen::VectorXd y = model.C * x + model.D.col(0);
    for (std::size_t k = 0; k < outputs; ++k) response.y[k][i] = y(static_cast<Eigen::Index>(k));
    x = phi * x + gamma;
  }
  const std::vector<TransferFunction> functions = TransferFunctions(model);
  for (std::size_t k = 0; k < outputs; ++k) {
    StepFigures figures = FinalValue(functions[k]);
    if (figures.ok) {
      figures = MeasureStep(response.t_s, response.y[k], figures.final_value);
    }
    response.figures.push_back(figures);
  }
  response.ok = true;
  return response;
}

}  // namespace blmd
