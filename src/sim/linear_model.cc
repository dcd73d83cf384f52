#include "blmd/sim/linear_model.h"

#include <algorithm>
#include <cmath>

#include "blmd/sim/parameters.h"
#include "blmd/sim/two_mass.h"

namespace blmd {

void LinearShaft(const ParameterSet& values, double torque_per_input, LinearModel* model) {
  const double J = values.Get("J"), B = values.Get("B");
  model->available = true;
  model->outputs = {"w", "theta"};
  model->C = Eigen::MatrixXd::Identity(2, 2);
  model->D = Eigen::MatrixXd::Zero(2, 1);
  // A two-mass shaft is linear: kept, so that the transfer functions, the Bode plot and the
  // exports show its resonance.
  if (values.Has("inertia_ratio") && values.Has("anti_resonance_hz")) {
    const double r = values.Get("inertia_ratio"), fa = values.Get("anti_resonance_hz");
    const double zeta = values.GetOr("shaft_damping_ratio", 0.0);
    const double share = values.GetOr("load_damping_share", 0.0);
    const TwoMassSides sides = TwoMassSides::Of(J, B, r, fa, zeta, share);
    model->states = {"w", "theta", "w_load", "twist"};
    model->A = Eigen::MatrixXd::Zero(4, 4);
    sides.SetRows(0, 2, 3, &model->A);
    model->A(1, 0) = 1.0;
    model->B = Eigen::MatrixXd::Zero(4, 1);
    model->B(0, 0) = torque_per_input / sides.Jm;
    model->C = Eigen::MatrixXd::Identity(2, 4);
    model->has_shaft = true;
    model->shaft = {J, B, torque_per_input, r, fa, zeta, share};
    return;
  }
  model->states = {"w", "theta"};
  model->A.resize(2, 2);
  model->A << -B / J, 0.0, 1.0, 0.0;
  model->B.resize(2, 1);
  model->B << torque_per_input / J, 0.0;
}

std::vector<TransferFunction> TransferFunctions(const LinearModel& model) {
  std::vector<TransferFunction> functions;
  if (!model.available) return functions;
  const Eigen::Index n = model.A.rows();
  // Faddeev-LeVerrier: det(sI - A) = sum_k c_k s^(n-k) with c_0 = 1, and
  // adj(sI - A) = sum_{k=1..n} M_k s^(n-k), M_1 = I, M_{k+1} = A·M_k + c_k·I,
  // c_k = -trace(A·M_k)/k.
  std::vector<Eigen::MatrixXd> M;
  std::vector<double> den = {1.0};
  Eigen::MatrixXd Mk = Eigen::MatrixXd::Identity(n, n);
  for (Eigen::Index k = 1; k <= n; ++k) {
    M.push_back(Mk);
    const Eigen::MatrixXd AM = model.A * Mk;
    const double c = -AM.trace() / static_cast<double>(k);
    den.push_back(c);
    Mk = AM + c * Eigen::MatrixXd::Identity(n, n);
  }
  for (Eigen::Index y = 0; y < model.C.rows(); ++y) {
    TransferFunction tf;
    tf.output = model.outputs[static_cast<std::size_t>(y)];
    // num(s) = sum_{k=1..n} (C_y M_k B) s^(n-k) + D_y den(s): n + 1 coefficients.
    std::vector<double> num(static_cast<std::size_t>(n) + 1, 0.0);
    for (Eigen::Index k = 0; k < n; ++k) {
      num[static_cast<std::size_t>(k) + 1] =
          (model.C.row(y) * M[static_cast<std::size_t>(k)] * model.B)(0, 0);
    }
    for (std::size_t k = 0; k < num.size(); ++k) num[k] += model.D(y, 0) * den[k];
    std::vector<double> d = den;
    // Zero up to rounding: the recursion leaves ~1e-16 relative where a coefficient is zero.
    auto zero = [](const std::vector<double>& p, double c) {
      double scale = 0.0;
      for (double x : p) scale = std::max(scale, std::abs(x));
      return std::abs(c) <= 1e-12 * scale;
    };
    for (double& c : num) c = zero(num, c) ? 0.0 : c;
    for (double& c : d) c = zero(d, c) ? 0.0 : c;
    // Cancel common factors of s: trailing zeros of both (an integrator state whose output
    // this is not).
    while (num.size() > 1 && d.size() > 1 && zero(num, num.back()) && zero(d, d.back())) {
      num.pop_back();
      d.pop_back();
    }
    std::size_t lead = 0;
    while (lead + 1 < num.size() && zero(num, num[lead])) ++lead;
    tf.numerator.assign(num.begin() + static_cast<std::ptrdiff_t>(lead), num.end());
    tf.denominator = d;
    functions.push_back(std::move(tf));
  }
  return functions;
}

}  // namespace blmd
