#include "ident/discovery/effect_search.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>

#include "blmd/constants.h"
#include "blmd/ident/optimizers/noise_model.h"
#include "blmd/io/csv.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/trace.h"
#include "ident/discovery/plausibility.h"
#include "ident/fit/jacobian.h"

namespace blmd::internal {
namespace {

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

// The torque scale T that sizes the candidates' search boxes (docs/discovery.md §2): the
// largest torque the record shows, the model's DriveTorqueScale at the current fit's
// values. dc_servo and blmd: the motor torque at the largest simulated current.
// rigid_load: the drive torque Kt max|u|, or the current model's damping torque B max|w|
// at its fitted values (w simulated) if that is larger. The second matters
// when the shaft moves without a drive: on a coast-down (u = 0) it is the torque that
// decelerates the shaft at its top speed (J |dw/dt| of the J, B model), where Kt max|u| is
// 0 and every search box would collapse to [0, 1e-12]. The measured acceleration is not
// used: differentiated twice from a logged speed, its maximum is noise (12 N m against
// B max|w| = 0.42 N m on the flywheel coast-down of docs/real-data.md). Driven from rest,
// B |w| of the J, B model stays below Kt max|u| (its steady state is B w = Kt u), so the
// scale changes only for records that start faster than the drive holds.
double TorqueScale(const FitProblem& problem, const ResidualAnalysis& analysis,
                   const std::vector<double>& values) {
  return std::max(problem.config().model->DriveTorqueScale(
                      problem.Parameters(values), analysis.i_max, analysis.u_max, analysis.w_max),
                  1e-12);
}

// Start values for a cogging torque Tcog sin(m theta + phase) from the speed residual in
// steady motion, where the response is linear: with J dw/dt = -Tcog sin(m theta + phase)
// and dtheta/dt = w nearly constant, w ripples by Tcog / (J m w) cos(m theta + phase), so
// the residual times w, regressed on cos(m theta) and sin(m theta), has coefficients
// a = (Tcog / (J m)) cos(phase) and b = -(Tcog / (J m)) sin(phase). The residual is
// detrended over one revolution around each sample first (as the angle spectrum is).
bool CoggingStart(const FitProblem& problem, const std::vector<double>& values, int order,
                  double w_max, double* tcog, double* phase) {
  const auto& observe = problem.observe();
  const auto column = std::find(observe.begin(), observe.end(), "w");
  if (column == observe.end()) return false;
  double J = problem.config().parameters.Get("J");
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    if (problem.free()[k].name == "J") J = values[k];
  }
  double a = 0.0, b = 0.0, cc = 0.0, ss = 0.0, cs = 0.0;
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    Trace simulated;
    if (!problem.Simulate(k, values, &simulated).ok()) return false;
    const auto& w = simulated.Column("w");
    const auto& theta = simulated.Column("theta");
    const auto& time = simulated.Column("t");
    const auto& measured = problem.traces()[k].trace.Column("w");
    const std::size_t n = w.size();
    std::vector<double> prefix(n + 1, 0.0);
    for (std::size_t r = 0; r < n; ++r) prefix[r + 1] = prefix[r] + (measured[r] - w[r]);
    const double rate = static_cast<double>(n - 1) / std::max(time.back() - time.front(), 1e-300);
    for (std::size_t r = 0; r < n; ++r) {
      if (std::abs(w[r]) <= 0.25 * w_max) continue;
      const std::size_t h = std::min(n / 4, static_cast<std::size_t>(kPi / std::abs(w[r]) * rate));
      const std::size_t lo = r >= h ? r - h : 0, hi = std::min(n, r + h + 1);
      const double detrended =
          (measured[r] - w[r]) - (prefix[hi] - prefix[lo]) / static_cast<double>(hi - lo);
      const double y = detrended * w[r];
      const double c = std::cos(order * theta[r]), s = std::sin(order * theta[r]);
      a += y * c;
      b += y * s;
      cc += c * c;
      ss += s * s;
      cs += c * s;
    }
  }
  const double det = cc * ss - cs * cs;
  if (!(det > 0.0)) return false;
  const double ca = (ss * a - cs * b) / det, cb = (cc * b - cs * a) / det;
  *tcog = J * order * std::hypot(ca, cb);
  *phase = std::atan2(-cb, ca);
  return std::isfinite(*tcog) && std::isfinite(*phase);
}

// Cogging orders of a rigid_load, ranked by the torque balance along the measured motion
// (an equation-error regression, as the inverse-dynamics identification of the EMPS
// benchmark): where the shaft turns steadily (measured |w| above a quarter of its maximum),
//   e = Kt u - J a - B w - T_effects(w)     (a: the measured acceleration)
// is regressed on [a, w, sign w, 1, sin(m theta), cos(m theta)] for every order m; the first
// four columns take up what J, B, Coulomb friction and a load torque still miss, and the fall
// of the sum of squares that the last two add ranks the orders. The residual of the output-
// error fit is a poor guide here: the speed ripple of a cogging torque falls as 1/m, a
// friction or stick misfit leaves strong low orders in it, and at the measured angle a
// cogging torque of any order can hold a shaft at rest (ODrive spin-ups, docs/real-data.md).
// The torque balance uses the recorded input directly, which only rigid_load allows (the
// drive torque of dc_servo and blmd is a state of the model): others keep the angle
// spectrum's orders. Returns the orders best first, with their (Tcog, phase) estimates.
struct OrderScreen {
  int order = 0;
  double reduction = 0.0;       // fall of the torque balance's sum of squares, (N·m)^2
  double share = 0.0;           // reduction / the sum of squares left by [a, w, sign w, 1]
  int lowest = 0, highest = 0;  // the range of orders screened
  double tcog = 0.0, phase = 0.0;
};

std::vector<OrderScreen> ScreenCoggingOrders(const FitProblem& problem,
                                             const std::vector<double>& values, int max_order) {
  std::vector<OrderScreen> ranked;
  if (!problem.config().model->traits().input_is_torque) return ranked;
  const ParameterSet parameters = problem.Parameters(values);
  const double J = parameters.Get("J"), B = parameters.Get("B"), Kt = parameters.Get("Kt");
  const ShaftEffects shaft = ShaftEffects::From(parameters, problem.config().effects, 0.0);
  // Measured angle, speed, acceleration and drive torque at every sample (central
  // differences over two samples each side: irregular time stamps are fine).
  struct Sample {
    double theta, w, a, torque;
    double half_window;  // s, half the acceleration's difference window
  };
  std::vector<Sample> samples;
  double path = 0.0, w_max = 0.0;
  constexpr std::size_t h = 2;
  for (const auto& trace : problem.traces()) {
    const std::vector<double> theta = MeasuredAngle(trace);
    const auto& t = trace.trace.Column("t");
    const auto& u = trace.trace.Column("u");
    const std::size_t n = theta.size();
    if (n < 4 * h + 1) continue;
    for (std::size_t k = 1; k < n; ++k) path += std::abs(theta[k] - theta[k - 1]);
    std::vector<double> w(n, 0.0);
    if (trace.trace.Has("w")) {
      w = trace.trace.Column("w");
    } else {
      for (std::size_t k = h; k + h < n; ++k)
        w[k] = (theta[k + h] - theta[k - h]) / (t[k + h] - t[k - h]);
    }
    for (std::size_t k = 2 * h; k + 2 * h < n; ++k) {
      const double a = (w[k + h] - w[k - h]) / (t[k + h] - t[k - h]);
      samples.push_back({theta[k], w[k], a, Kt * u[k], 0.5 * (t[k + h] - t[k - h])});
      w_max = std::max(w_max, std::abs(w[k]));
    }
  }
  if (!(path > kPi) || samples.empty()) return ranked;
  // Order 1 (one period per revolution) is gravity's (PlanGravity), not cogging's.
  const int min_order = std::max(2, static_cast<int>(std::ceil(3.0 * 2.0 * kPi / path)));
  std::vector<const Sample*> moving;
  for (const auto& sample : samples) {
    if (std::abs(sample.w) > 0.25 * w_max) moving.push_back(&sample);
  }
  const auto n = static_cast<Eigen::Index>(moving.size());
  if (n < 20) return ranked;
  // Orders the measured acceleration resolves: the central difference over +-T passes a
  // ripple of angular frequency m |w| with the gain sin(m |w| T) / (m |w| T), so orders with
  // m |w| T above pi/2 (gain below 0.64, null at pi) at the typical (median) sample are
  // left out rather than ranked on what the differences make of them.
  std::vector<double> resolved;
  resolved.reserve(moving.size());
  for (const Sample* s : moving) resolved.push_back(0.5 * kPi / (std::abs(s->w) * s->half_window));
  std::nth_element(resolved.begin(), resolved.begin() + static_cast<long>(resolved.size() / 2),
                   resolved.end());
  max_order = std::min(max_order, static_cast<int>(resolved[resolved.size() / 2]));
  if (max_order < min_order) return ranked;
  Eigen::MatrixXd design(n, 6);
  Eigen::VectorXd error(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const Sample& s = *moving[static_cast<std::size_t>(r)];
    const double sign = s.w > 0.0 ? 1.0 : -1.0;
    error(r) = s.torque - J * s.a - B * s.w - shaft.NonFrictionTorque(s.theta) -
               shaft.DragTorque(s.w) - sign * shaft.FrictionMagnitude(s.w);
    design(r, 0) = s.a;
    design(r, 1) = s.w;
    design(r, 2) = sign;
    design(r, 3) = 1.0;
  }
  const Eigen::VectorXd base_fit =
      design.leftCols(4) * design.leftCols(4).colPivHouseholderQr().solve(error);
  const double base_sse = (error - base_fit).squaredNorm();
  for (int order = min_order; order <= max_order; ++order) {
    for (Eigen::Index r = 0; r < n; ++r) {
      const double angle = order * moving[static_cast<std::size_t>(r)]->theta;
      design(r, 4) = std::sin(angle);
      design(r, 5) = std::cos(angle);
    }
    const Eigen::VectorXd x = design.colPivHouseholderQr().solve(error);
    if (!x.allFinite()) continue;
    // T_effects = Tcog sin(m theta + phase) = a sin + b cos, and e = T_cog + ...: a = x4, b = x5.
    OrderScreen screen;
    screen.order = order;
    screen.reduction = base_sse - (error - design * x).squaredNorm();
    screen.share = base_sse > 0.0 ? screen.reduction / base_sse : 0.0;
    screen.lowest = min_order;
    screen.highest = max_order;
    screen.tcog = std::hypot(x(4), x(5));
    screen.phase = std::atan2(x(5), x(4));
    ranked.push_back(screen);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const OrderScreen& l, const OrderScreen& r) {
    return l.reduction > r.reduction;
  });
  return ranked;
}

// Cogging orders of dc_servo and blmd ranked by the linearised response at the measured
// angle: for each order m, the model's response to a small torque eps sin(m theta_meas)
// and eps cos(m theta_meas) (the cogging effect at the measured angle, as discovery fits it)
// gives two sensitivity columns S_s, S_c of the weighted residual; with the Jacobian of the
// model's own free parameters (J, B, ...) beside them, the fall of the residual's sum of
// squares that the m columns add (a Gauss-Newton step on all parameters) ranks the orders,
// and their coefficients (a, b) = Tcog (cos phase, sin phase) are the start. Unlike the raw angle
// spectrum of the speed residual (whose ripple falls as 1/m and which a friction misfit
// fills with low orders and their harmonics), this asks what a cogging torque of each order
// would do to every observed column through the model's own dynamics (a case: orders 40,
// 29, 57 had been added for 8, 8, 12). Empty when the traces record no angle.
std::vector<OrderScreen> RankOrdersByResponse(const FitProblem& problem,
                                              const std::vector<double>& values,
                                              double torque_scale, int lowest, int highest) {
  std::vector<OrderScreen> ranked;
  // The current model's residual and its Jacobian in its own free parameters (J, B, ...):
  // an order is credited only with what they cannot take up (a Gauss-Newton step on all
  // of them together), or low orders would be ranked on the misfit that J and B absorb.
  std::vector<double> r0;
  Eigen::MatrixXd jacobian;
  DifferenceRule rule;
  rule.step = kScreeningDifferenceStep;
  rule.central = false;
  if (!FiniteDifferenceJacobian(problem, ToSearchCoordinates(problem, values), rule, nullptr, &r0,
                                &jacobian))
    return ranked;
  const auto n = static_cast<Eigen::Index>(r0.size());
  const Eigen::VectorXd r = Eigen::Map<const Eigen::VectorXd>(r0.data(), n);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(jacobian);
  const Eigen::MatrixXd basis = qr.householderQ() * Eigen::MatrixXd::Identity(n, jacobian.cols());
  auto purify = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return v - basis * (basis.transpose() * v);
  };
  const Eigen::VectorXd y = purify(-r);  // a S_s + b S_c should cancel what is left of r0
  const double total = y.squaredNorm();
  if (!(total > 0.0)) return ranked;
  const double eps = 1e-3 * torque_scale;
  for (int order = lowest; order <= highest; ++order) {
    Config config = problem.config();
    ParameterSet cogging;
    cogging.Set("Tcog", 0.0);
    cogging.Set("periods", static_cast<double>(order));
    cogging.Set("phase", 0.0);
    config.AddEffect("cogging", cogging);
    std::vector<FreeParameter> free = problem.free();
    free.push_back(Free("Tcog", 0.0, 1.0));
    free.push_back(Free("phase", -2.0 * kPi, 2.0 * kPi));
    FitProblem probe(config, problem.traces(), problem.observe(), free);
    if (!probe.ForceEffectAngle()) return {};
    std::vector<std::vector<double>> points(3, values);
    points[0].insert(points[0].end(), {0.0, 0.0});
    points[1].insert(points[1].end(), {eps, 0.0});
    points[2].insert(points[2].end(), {eps, 0.5 * kPi});
    std::vector<std::vector<double>> residuals;
    const std::vector<Evaluation> evaluations = probe.EvaluateBatch(points, &residuals);
    if (!evaluations[0].ok || !evaluations[1].ok || !evaluations[2].ok) continue;
    Eigen::MatrixXd S(n, 2);
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto i = static_cast<std::size_t>(k);
      S(k, 0) = (residuals[1][i] - residuals[0][i]) / eps;
      S(k, 1) = (residuals[2][i] - residuals[0][i]) / eps;
    }
    S.col(0) = purify(S.col(0));
    S.col(1) = purify(S.col(1));
    const Eigen::Matrix2d normal = S.transpose() * S;
    const Eigen::Vector2d rhs = S.transpose() * y;
    const double det = normal.determinant();
    if (!(det > 1e-12 * normal(0, 0) * normal(1, 1)) || !std::isfinite(det)) continue;
    const Eigen::Vector2d ab = normal.ldlt().solve(rhs);
    OrderScreen screen;
    screen.order = order;
    screen.reduction = ab.dot(rhs);
    screen.share = screen.reduction / total;
    screen.lowest = lowest;
    screen.highest = highest;
    screen.tcog = std::hypot(ab(0), ab(1));
    screen.phase = std::atan2(ab(1), ab(0));
    if (std::isfinite(screen.reduction)) ranked.push_back(screen);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const OrderScreen& l, const OrderScreen& r) {
    return l.reduction > r.reduction;
  });
  return ranked;
}

CandidatePlan PlanCoulombFriction(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale;
  plan.free = {Free("Tc", 0.0, T)};
  for (double f : {0.003, 0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * T});
  plan.amplitude = "Tc";
  return plan;
}

CandidatePlan PlanLoadTorque(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale;
  plan.free = {Free("TL", -T, T)};
  for (double f : {0.01, 0.03, 0.1, 0.3}) {
    plan.starts.push_back({f * T});
    plan.starts.push_back({-f * T});
  }
  plan.amplitude = "TL";
  return plan;
}

CandidatePlan PlanQuadraticDrag(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale, w_max = context.w_max;
  const double scale = T / (w_max * w_max);
  plan.free = {Free("Cd", 0.0, scale)};
  for (double f : {0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * scale});
  plan.amplitude = "Cd";
  return plan;
}

CandidatePlan PlanAsymmetricViscous(const PlanContext& context) {
  CandidatePlan plan;
  // On a record that turns one way only, dB |w| is dB w: B's own term, so B and dB cannot be
  // told apart (a rank-deficient Jacobian, no interval) and nothing is learnt of the other
  // direction (a case: added on every constant-torque spin-up of a reaction wheel, each with
  // J and no interval). The current model's speed decides (its simulation has no noise at
  // rest), or a measured speed that clearly reverses (past a tenth of its peak both ways, far
  // above a speed's noise at rest) where a missing effect keeps the model's from reversing.
  double peak = 0.0, forwards = 0.0, backwards = 0.0;
  for (const FitTrace& trace : context.problem.traces()) {
    if (!trace.trace.Has("w")) continue;
    for (double w : trace.trace.Column("w")) {
      peak = std::max(peak, std::abs(w));
      forwards = std::max(forwards, w);
      backwards = std::max(backwards, -w);
    }
  }
  const bool measured_reverses = peak > 0.0 && std::min(forwards, backwards) > 0.1 * peak;
  if (!context.analysis.w_changes_sign && !measured_reverses) {
    plan.applicable = false;
    plan.not_applicable =
        "the shaft turned one way only: dB |w| is then part of B; record both directions";
    return plan;
  }
  const double T = context.torque_scale, w_max = context.w_max;
  // dB |w|: the damping B + dB forwards, B - dB backwards. Searched over the damping that
  // would take the whole torque scale at the top speed, either sign; valid while both
  // directions keep a positive damping (|dB| < B).
  const double scale = T / w_max;
  plan.free = {Free("dB", -scale, scale)};
  for (double f : {0.01, 0.03, 0.1, 0.3}) {
    plan.starts.push_back({f * scale});
    plan.starts.push_back({-f * scale});
  }
  plan.amplitude = "dB";
  plan.constraint = [](const ParameterSet& p) -> std::string {
    const double dB = p.Get("dB"), B = p.Get("B");
    if (std::abs(dB) < B) return "";
    return "|dB| = " + G(std::abs(dB)) + " is not below B = " + G(B) +
           " (the damping of one direction would be negative)";
  };
  return plan;
}

CandidatePlan PlanStribeck(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale, w_max = context.w_max;
  plan.free = {Free("Ts", 0.0, T), Free("ws", 1e-3 * w_max, w_max, true)};
  for (double f : {0.01, 0.03, 0.1, 0.3}) {
    for (double g : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * T, g * w_max});
  }
  plan.amplitude = "Ts";
  // A Stribeck friction is a dip of the friction at low speed: the record must show the
  // friction settle on its Coulomb plateau after it, exp(-(w_max/ws)^2) <= exp(-4) (the
  // Stribeck part below 2 % of Ts at the top speed), i.e. ws <= w_max / 2; a larger ws only
  // reshapes a Coulomb friction over the whole range (a case: ws of 0.54-0.63 w_max named
  // on traces with Coulomb friction and cogging).
  // Nor can a dip narrower than the measured speed's resolution be seen: a speed quantised in
  // steps of q (an encoder's count over the sampling interval, when w is derived from it) is
  // 0 or at least q, and a curve of width ws < q is then static friction, which the model's
  // sticking already has (a case: ws 0.05 and 0.1 rad/s added on frictionless closed-loop
  // records whose derived speed moves in steps of 0.63 and 1.26 rad/s).
  double resolution = 0.0;
  for (const auto& trace : context.problem.traces()) {
    if (trace.trace.Has("w"))
      resolution = std::max(resolution, QuantisationStep(trace.trace.Column("w")));
  }
  plan.constraint = [w_max, resolution](const ParameterSet& p) -> std::string {
    const double ws = p.Get("ws");
    if (ws < resolution) {
      return "ws = " + G(ws) + " is below the measured speed's resolution (" + G(resolution) +
             " rad/s steps): no Stribeck dip can be seen in these data";
    }
    if (ws <= 0.5 * w_max) return "";
    return "ws = " + G(ws) + " is not well inside the speed range (at most half of " + G(w_max) +
           ", where the curve reaches its Coulomb plateau): no Stribeck dip in these data";
  };
  return plan;
}

CandidatePlan PlanCogging(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale;
  const FitProblem& problem = context.problem;
  const ResidualAnalysis& analysis = context.analysis;
  const std::vector<double>& values = context.values;
  // Periods per revolution. rigid_load: the one order that the torque balance along the
  // measured motion explains best (ScreenCoggingOrders), with its estimate as a start.
  // Other models: the four strongest orders of the residual's angle spectrum
  // (diagnostics.cc: detrended, steady motion only), velocity first, then current.
  bool turned = false;
  for (const auto& d : analysis.columns) turned = turned || !d.angle_peaks.empty();
  if (!turned) {
    plan.applicable = false;
    plan.not_applicable = "the shaft turns too little for an angle spectrum";
    return plan;
  }
  std::vector<int> orders;
  std::vector<std::vector<double>> linear_starts;
  const std::vector<OrderScreen> screened =
      ScreenCoggingOrders(problem, values, DiagnosticsOptions().max_order);
  if (!screened.empty()) {
    orders.push_back(screened.front().order);
    linear_starts.push_back(
        {std::clamp(screened.front().tcog, 1e-6 * T, 0.9 * T), screened.front().phase});
    plan.evidence = "torque balance along the measured motion (orders " +
                    std::to_string(screened.front().lowest) + "-" +
                    std::to_string(screened.front().highest) + "): order " +
                    std::to_string(screened.front().order) + " explains " +
                    G(100.0 * screened.front().share, 3) + " % of its residual";
    if (screened.size() > 1) {
      plan.evidence += " (next: order " + std::to_string(screened[1].order) + ", " +
                       G(100.0 * screened[1].share, 3) + " %)";
    }
  }
  if (orders.empty()) {
    // dc_servo, blmd: the eight orders whose linearised response explains most, from 2
    // (order 1 is gravity's) and completing three periods over the angle travelled.
    int lowest = 2;
    double travelled = 0.0;
    for (const FitTrace& trace : problem.traces()) {
      const std::vector<double> angle = MeasuredAngle(trace);
      for (std::size_t r = 1; r < angle.size(); ++r) travelled += std::abs(angle[r] - angle[r - 1]);
    }
    // (in double first: a shaft that hardly turns would overflow the int)
    const double fewest = travelled > 0.0 ? std::ceil(3.0 * 2.0 * kPi / travelled) : 1e300;
    lowest = fewest > DiagnosticsOptions().max_order ? DiagnosticsOptions().max_order + 1
                                                     : std::max(lowest, static_cast<int>(fewest));
    // Orders above the samples' Nyquist order in angle are aliased onto lower ones (a case:
    // 62/rev chosen for 8/rev sampled 35 times per revolution): not ranked.
    int highest = DiagnosticsOptions().max_order;
    if (analysis.angle_nyquist_order > 0) highest = std::min(highest, analysis.angle_nyquist_order);
    const std::vector<OrderScreen> ranked =
        RankOrdersByResponse(problem, values, T, lowest, highest);
    // The eight best are refit (the refit chooses among them by BIC): the ranking linearises
    // a response that a cogging field makes nonlinear at low speed, and the right order came
    // 5th-8th on two of twelve held-out Coulomb + cogging cases (STUDY_SEED 1 and 2) when
    // four were refit.
    constexpr std::size_t kOrdersRefit = 8;
    for (std::size_t k = 0; k < ranked.size() && k < kOrdersRefit; ++k) {
      orders.push_back(ranked[k].order);
      linear_starts.push_back({std::clamp(ranked[k].tcog, 1e-6 * T, 0.9 * T), ranked[k].phase});
      plan.alternative_evidence.push_back(
          "linearised response at the measured angle (orders " + std::to_string(lowest) + "-" +
          std::to_string(ranked[k].highest) + "): order " + std::to_string(ranked[k].order) +
          " explains " + G(100.0 * ranked[k].share, 3) + " % of the residual (rank " +
          std::to_string(k + 1) +
          (k == 0 && ranked.size() > 1 ? "; next: order " + std::to_string(ranked[1].order) + ", " +
                                             G(100.0 * ranked[1].share, 3) + " %"
                                       : std::string()) +
          ")");
    }
  }
  if (orders.empty()) {  // no angle to linearise at: the residual's angle spectrum
    for (const char* column : {"w", "theta", "i"}) {
      for (const auto& d : analysis.columns) {
        if (d.column != column) continue;
        for (const auto& peak : d.angle_peaks) {
          if (peak.order >= 2 && orders.size() < 4 &&
              std::find(orders.begin(), orders.end(), peak.order) == orders.end()) {
            orders.push_back(peak.order);
          }
        }
      }
    }
  }
  if (orders.empty()) {
    // E.g. a shaft so fast that the samples resolve no order from 2 up (the Nyquist order in
    // angle below the lowest order that completes three periods, or below 2).
    plan.applicable = false;
    plan.not_applicable =
        "no cogging order from 2 to the samples' Nyquist order in angle has a response to rank";
    return plan;
  }
  plan.free = {Free("Tcog", 0.0, T), Free("phase", -2.0 * kPi, 2.0 * kPi)};
  for (int order : orders) {
    plan.fixed_alternatives.push_back({{"periods", static_cast<double>(order)}});
    // The linear-response estimate of this order's amplitude and phase is a start point
    // (per alternative), besides the generic grid.
    std::vector<std::vector<double>> starts;
    const std::size_t index = plan.fixed_alternatives.size() - 1;
    if (index < linear_starts.size()) starts.push_back(linear_starts[index]);
    double tcog = 0.0, phase = 0.0;
    if (CoggingStart(problem, values, order, analysis.w_max, &tcog, &phase)) {
      starts.push_back({std::clamp(tcog, 1e-6 * T, 0.9 * T), phase});
    }
    plan.alternative_starts.push_back(starts);
  }
  for (double f : {0.01, 0.03, 0.1, 0.3}) {
    for (int k = 0; k < 8; ++k) plan.starts.push_back({f * T, -kPi + 0.25 * kPi * k});
  }
  plan.amplitude = "Tcog";
  return plan;
}

// The torque balance along the measured motion for the position-dependent candidates
// (spring, gravity), in integral form. At every sample with a measured drive torque
// (rigid_load: Kt u; dc_servo: Kt i from the measured current) the current model leaves
//   e = T_drive - B w - T_effects(theta, w) = J dw/dt + T(theta) + dB w
// when a position torque T(theta) is missing (dB what B still misses). Integrated from the
// trace's start, int e dt = J (w - w(0)) + dB int w dt + int T(theta) dt: regressed on
// [w, int w dt, 1, int of the columns of theta], the last coefficients are a linearised start.
// The integral form needs no acceleration: differentiated from a speed with 1 % noise at
// 1 kHz, the acceleration's noise is as large as the signal, and a regression on it put the
// spring's K at -14 times its value on the DC-servo round trip (tests/position_discovery_test).
struct TorqueBalance {
  struct Sample {
    std::size_t trace;
    double t, theta, w, error;
  };
  std::vector<Sample> samples;
};

// The measured angle's range over every trace (false when no trace has an angle).
bool MeasuredAngleRange(const FitProblem& problem, double* lowest, double* highest) {
  bool any = false;
  for (const auto& trace : problem.traces()) {
    const std::vector<double> theta = MeasuredAngle(trace);
    for (double x : theta) {
      if (!std::isfinite(x)) continue;
      *lowest = any ? std::min(*lowest, x) : x;
      *highest = any ? std::max(*highest, x) : x;
      any = true;
    }
  }
  return any;
}

bool MeasureTorqueBalance(const FitProblem& problem, const std::vector<double>& values,
                          TorqueBalance* balance) {
  const Config& config = problem.config();
  const std::string model(config.model->name());
  const bool torque_input = config.model->traits().input_is_torque;
  if (!torque_input && model != "dc_servo") return false;  // blmd: the torque is a state
  const ParameterSet parameters = problem.Parameters(values);
  const double B = parameters.Get("B"), Kt = parameters.Get("Kt");
  const double i0 = std::find(config.effects.begin(), config.effects.end(), "current_offset") !=
                            config.effects.end()
                        ? parameters.Get("i0")
                        : 0.0;
  const ShaftEffects shaft = ShaftEffects::From(parameters, config.effects, 0.0);
  for (std::size_t index = 0; index < problem.traces().size(); ++index) {
    const FitTrace& trace = problem.traces()[index];
    const std::vector<double> theta = MeasuredAngle(trace);
    const auto& t = trace.trace.Column("t");
    const std::size_t n = theta.size();
    if (n < 20) continue;
    if (!torque_input && !trace.trace.Has("i")) continue;
    const std::vector<double>& drive = trace.trace.Column(torque_input ? "u" : "i");
    const std::vector<double> w = MeasuredSpeed(trace, theta);
    for (std::size_t k = 0; k < n; ++k) {
      const double torque = torque_input ? Kt * drive[k] : Kt * (drive[k] - i0);
      double friction = 0.0;
      if (shaft.has_friction() && w[k] != 0.0)
        friction = (w[k] > 0.0 ? 1.0 : -1.0) * shaft.FrictionMagnitude(w[k]);
      const double e =
          torque - B * w[k] - shaft.NonFrictionTorque(theta[k]) - shaft.DragTorque(w[k]) - friction;
      if (!std::isfinite(e) || !std::isfinite(theta[k])) return false;
      balance->samples.push_back({index, t[k], theta[k], w[k], e});
    }
  }
  return balance->samples.size() >= 20;
}

// Regresses the integrated balance on [w, int w dt, 1, int of each extra column of theta]
// (trapezoidal integrals from each trace's start); the coefficients of the extra columns,
// and the share of the sum of squares left by the first three that they explain.
bool RegressOnAngle(const TorqueBalance& balance,
                    const std::vector<std::function<double(double)>>& columns,
                    std::vector<double>* coefficients, double* share) {
  const auto n = static_cast<Eigen::Index>(balance.samples.size());
  const auto m = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd design(n, 3 + m);
  Eigen::VectorXd integral(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const auto& s = balance.samples[static_cast<std::size_t>(r)];
    const bool first = r == 0 || balance.samples[static_cast<std::size_t>(r - 1)].trace != s.trace;
    design(r, 0) = s.w;
    design(r, 2) = 1.0;
    if (first) {
      integral(r) = 0.0;
      design(r, 1) = 0.0;
      for (Eigen::Index c = 0; c < m; ++c) design(r, 3 + c) = 0.0;
      continue;
    }
    const auto& p = balance.samples[static_cast<std::size_t>(r - 1)];
    const double h = 0.5 * (s.t - p.t);
    integral(r) = integral(r - 1) + h * (s.error + p.error);
    design(r, 1) = design(r - 1, 1) + h * (s.w + p.w);
    for (Eigen::Index c = 0; c < m; ++c) {
      const auto& column = columns[static_cast<std::size_t>(c)];
      design(r, 3 + c) = design(r - 1, 3 + c) + h * (column(s.theta) + column(p.theta));
    }
  }
  const Eigen::VectorXd base = design.leftCols(3).colPivHouseholderQr().solve(integral);
  const double base_sse = (integral - design.leftCols(3) * base).squaredNorm();
  const Eigen::VectorXd x = design.colPivHouseholderQr().solve(integral);
  if (!x.allFinite()) return false;
  coefficients->assign(x.data() + 3, x.data() + 3 + m);
  *share = base_sse > 0.0 ? (base_sse - (integral - design * x).squaredNorm()) / base_sse : 0.0;
  return true;
}

// The most turns a spring candidate may wind over (PlanSpring).
constexpr double kSpringMaxTurns = 100.0;

// spring: T_effects = K (theta - theta0) = K theta - K theta0, linear in (K, K theta0). K is
// searched up to the stiffness whose torque over the measured angle's range is a few torque
// scales, theta0 over the range widened by twice its width either side; the start is the
// integrated torque balance's regression on [theta, 1] (K and -K theta0), then a grid.
CandidatePlan PlanSpring(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale;
  double lowest = 0.0, highest = 0.0;
  if (!MeasuredAngleRange(context.problem, &lowest, &highest) || !(highest - lowest > 1e-6)) {
    plan.applicable = false;
    plan.not_applicable = "needs a measured angle that moves (theta or w)";
    return plan;
  }
  const double span = highest - lowest, middle = 0.5 * (lowest + highest);
  double k_scale = T / span;
  std::vector<double> linear;
  TorqueBalance balance;
  std::vector<double> x;
  double share = 0.0;
  if (MeasureTorqueBalance(context.problem, context.values, &balance) &&
      RegressOnAngle(balance, {[](double theta) { return theta; }, [](double) { return 1.0; }}, &x,
                     &share) &&
      x[0] > 0.0) {
    const double theta0 = std::clamp(-x[1] / x[0], lowest - 2.0 * span, highest + 2.0 * span);
    linear = {x[0], theta0};
    k_scale = std::max(k_scale, x[0]);
    plan.evidence =
        "torque balance along the measured angle: K (theta - theta0) with K = " + G(x[0]) +
        " N·m/rad, theta0 = " + G(theta0) + " rad explains " + G(100.0 * share, 3) +
        " % of its residual";
  }
  plan.free = {Free("K", 0.0, 4.0 * k_scale),
               Free("theta0", lowest - 2.0 * span, highest + 2.0 * span)};
  if (!linear.empty()) plan.starts.push_back(linear);
  for (double f : {0.03, 0.1, 0.3, 1.0}) {
    for (double theta0 : {lowest, middle, highest}) plan.starts.push_back({f * T / span, theta0});
  }
  plan.amplitude = "K";
  // A spring must be held where the shaft rests, and a rotary one cannot be wound more than a
  // turn beyond the motion (a linear one more than the motion's span beyond it): a rest
  // angle turns away is a slow drift or a load, not a spring.
  const auto held = HeldAtStandstillCheck(context.problem, context.w_max, T, "spring");
  const bool linear_axis = context.problem.config().linear_axis;
  const double beyond = linear_axis ? span : kTwoPi;
  plan.constraint = [held, linear_axis, beyond, lowest,
                     highest](const ParameterSet& p) -> std::string {
    const double theta0 = p.Get("theta0");
    // Nor does a torsion spring wind over a hundred turns (a retractor's clock spring winds a
    // few tens): on a shaft that turned more, the shape is a slow drift or a load.
    if (!linear_axis && highest - lowest > kSpringMaxTurns * kTwoPi) {
      return "implausible: the shaft turns " + G((highest - lowest) / kTwoPi, 4) +
             " revolutions, more than any torsion spring winds (" + G(kSpringMaxTurns, 3) +
             "): no spring acts on this shaft";
    }
    const double outside = std::max({0.0, lowest - theta0, theta0 - highest});
    if (outside > beyond) {
      return "implausible: its rest angle " + G(theta0) + " lies " + G(outside) +
             " beyond the motion [" + G(lowest) + ", " + G(highest) + "] (more than " +
             (linear_axis ? std::string("the motion's span") : std::string("a turn")) +
             "): no spring acts on this shaft";
    }
    return held(p);
  };
  return plan;
}

// gravity: T_effects = Tg sin(theta + phase) = Tg cos(phase) sin(theta) + Tg sin(phase)
// cos(theta), linear in (Tg cos phase, Tg sin phase): the integrated torque balance
// regressed on [sin theta, cos theta] (no constant torque: over a swing of less than a
// revolution cos theta is nearly one, and a constant would take the torque's mean from it)
// gives the start. Tg is
// searched up to a few torque scales (a pendulum that only swings may be heavier than the
// drive), the phase over two turns, as cogging's.
CandidatePlan PlanGravity(const PlanContext& context) {
  CandidatePlan plan;
  const double T = context.torque_scale;
  double lowest = 0.0, highest = 0.0;
  if (!MeasuredAngleRange(context.problem, &lowest, &highest) || !(highest - lowest > 1e-3)) {
    plan.applicable = false;
    plan.not_applicable = "needs a measured angle that moves (theta or w)";
    return plan;
  }
  // One period per revolution must be resolved by the samples, with a margin: a shaft that
  // turns more than a quarter of a revolution between samples (the samples' Nyquist order in
  // angle below 2) aliases any slow residual onto "one period per revolution" (a 100 Hz
  // record of a wheel at 2500 rpm: 0.4 turns per sample).
  if (TurnsBetweenSamples(context.problem) > 0.25) {
    plan.applicable = false;
    plan.not_applicable =
        "the samples resolve no period per revolution (the shaft turns more "
        "than a quarter of a revolution between samples)";
    return plan;
  }
  double tg_scale = T;
  std::vector<double> linear;
  TorqueBalance balance;
  std::vector<double> x;
  double share = 0.0;
  if (MeasureTorqueBalance(context.problem, context.values, &balance) &&
      RegressOnAngle(balance,
                     {[](double theta) { return std::sin(theta); },
                      [](double theta) { return std::cos(theta); }},
                     &x, &share)) {
    const double tg = std::hypot(x[0], x[1]), phase = std::atan2(x[1], x[0]);
    if (tg > 0.0 && std::isfinite(tg)) {
      linear = {tg, phase};
      tg_scale = std::max(tg_scale, tg);
      plan.evidence =
          "torque balance along the measured angle: Tg sin(theta + phase) with Tg = " + G(tg) +
          " N·m, phase = " + G(phase, 3) + " rad explains " + G(100.0 * share, 3) +
          " % of its residual";
    }
  }
  plan.free = {Free("Tg", 0.0, 4.0 * tg_scale), Free("gravity_phase", -2.0 * kPi, 2.0 * kPi)};
  if (!linear.empty()) plan.starts.push_back(linear);
  for (double f : {0.03, 0.1, 0.3, 1.0}) {
    for (int k = 0; k < 8; ++k) plan.starts.push_back({f * T, -kPi + 0.25 * kPi * k});
  }
  plan.amplitude = "Tg";
  // Gravity must be held where the shaft rests: a rotor that rests at any angle with no
  // drive torque carries no unbalanced mass.
  plan.constraint = HeldAtStandstillCheck(context.problem, context.w_max, T, "gravity");
  return plan;
}

CandidatePlan PlanDeadTime(const PlanContext& context) {
  CandidatePlan plan;
  const ResidualAnalysis& analysis = context.analysis;
  const double u_max = std::max(analysis.u_max, 1e-9);
  plan.free = {Free("Vdt", 0.0, 0.5 * u_max)};
  for (double f : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * u_max});
  plan.amplitude = "Vdt";
  return plan;
}

CandidatePlan PlanCurrentOffset(const PlanContext& context) {
  CandidatePlan plan;
  const ResidualAnalysis& analysis = context.analysis;
  const bool observes_i = context.observes_i;
  if (!observes_i) {
    plan.applicable = false;
    plan.not_applicable = "needs the current i among the observed columns";
    return plan;
  }
  const double i_max = std::max(analysis.i_max, 1e-9);
  plan.free = {Free("i0", -i_max, i_max)};
  double mean = 0.0;
  for (const auto& d : analysis.columns) {
    if (d.column == "i") mean = d.mean;
  }
  plan.starts.push_back({std::clamp(mean, -0.9 * i_max, 0.9 * i_max)});
  plan.amplitude = "i0";
  return plan;
}

}  // namespace

const std::vector<EffectSearch>& EffectSearchRegistry() {
  static const std::vector<EffectSearch> registry = {
      {"coulomb_friction", PlanCoulombFriction, Pointer::kSignOfW},
      {"load_torque", PlanLoadTorque, Pointer::kResidualMean},
      {"quadratic_drag", PlanQuadraticDrag, Pointer::kResidualMean},
      {"asymmetric_viscous", PlanAsymmetricViscous, Pointer::kSignOfW},
      {"stribeck", PlanStribeck, Pointer::kSignOfW},
      {"cogging", PlanCogging, Pointer::kAnglePeak},
      {"spring", PlanSpring, Pointer::kAngleDependence},
      {"gravity", PlanGravity, Pointer::kAngleDependence},
      {"two_mass", PlanTwoMass, Pointer::kInputPast},
      {"dead_time", PlanDeadTime, Pointer::kSignOfI},
      {"current_offset", PlanCurrentOffset, Pointer::kResidualMean},
  };
  return registry;
}

const EffectSearch* FindEffectSearch(std::string_view effect) {
  for (const auto& search : EffectSearchRegistry()) {
    if (search.effect == effect) return &search;
  }
  return nullptr;
}

CandidatePlan PlanCandidate(const std::string& effect, const FitProblem& problem,
                            const ResidualAnalysis& analysis, const std::vector<double>& values) {
  const EffectSearch* search = FindEffectSearch(effect);
  if (!search) {
    CandidatePlan plan;
    plan.effect = effect;
    plan.applicable = false;
    plan.not_applicable = "no discovery plan for this effect";
    return plan;
  }
  const auto& observe = problem.observe();
  const PlanContext context{problem,
                            analysis,
                            values,
                            TorqueScale(problem, analysis, values),
                            std::max(analysis.w_max, 1e-9),
                            std::find(observe.begin(), observe.end(), "i") != observe.end()};
  CandidatePlan plan = search->plan(context);
  plan.effect = effect;
  return plan;
}

std::string PointingDiagnostic(const std::string& effect, const ResidualAnalysis& analysis,
                               int order) {
  std::string text;
  // The diagnostic that points at this effect, from the column where it is strongest.
  const ColumnDiagnostics* strongest = nullptr;
  auto pick = [&](auto score) {
    for (const auto& d : analysis.columns) {
      if (score(d) > 0.0 && (!strongest || score(d) > score(*strongest))) strongest = &d;
    }
  };
  const EffectSearch* search = FindEffectSearch(effect);
  const Pointer pointer = search ? search->pointer : Pointer::kResidualMean;
  if (pointer == Pointer::kSignOfW) {
    pick([](const ColumnDiagnostics& d) {
      return d.sign_w.available ? std::abs(d.sign_w.t_statistic) : 0.0;
    });
    if (strongest)
      text += "; " + strongest->column +
              " residual mean differs by sign of w (t = " + G(strongest->sign_w.t_statistic, 3) +
              ")";
  } else if (pointer == Pointer::kSignOfI) {
    pick([](const ColumnDiagnostics& d) {
      return d.sign_i.available ? std::abs(d.sign_i.t_statistic) : 0.0;
    });
    if (strongest)
      text += "; " + strongest->column +
              " residual mean differs by sign of i (t = " + G(strongest->sign_i.t_statistic, 3) +
              ")";
  } else if (pointer == Pointer::kAnglePeak) {
    pick([](const ColumnDiagnostics& d) {
      return d.angle_peaks.empty() ? 0.0 : d.angle_peaks.front().ratio;
    });
    if (strongest) {
      const AnglePeak& top = strongest->angle_peaks.front();
      const AnglePeak* cited = &top;
      if (order > 0) {  // the order added: its own peak, where the spectrum lists it
        cited = nullptr;
        for (const auto& peak : strongest->angle_peaks) {
          if (peak.order == order) cited = &peak;
        }
      }
      if (cited) {
        text += "; " + strongest->column + " residual peaks at " + std::to_string(cited->order) +
                " periods/rev (" + G(cited->ratio, 3) + " x the spectrum's median)";
      }
      if (order > 0 && top.order != order) {
        text += "; the angle spectrum's strongest peak is at " + std::to_string(top.order) +
                " periods/rev (" + G(top.ratio, 3) + " x), order " + std::to_string(order) +
                " was chosen by the refit";
      }
    }
  } else if (pointer == Pointer::kAngleDependence || pointer == Pointer::kInputPast) {
    // The torque balance's regression on the measured angle, quoted by the plan's evidence
    // (PlanSpring, PlanGravity), and the input-residual test quoted by PlanTwoMass's, say it;
    // the residual's diagnostics have no such statistic.
  } else {
    pick([](const ColumnDiagnostics& d) { return d.rms > 0.0 ? std::abs(d.mean) / d.rms : 0.0; });
    if (strongest)
      text += "; " + strongest->column + " residual mean " + G(strongest->mean) + " (rms " +
              G(strongest->rms) + ")";
  }
  return text;
}

}  // namespace blmd::internal
