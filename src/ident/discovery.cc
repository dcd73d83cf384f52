#include "blmd/ident/discovery.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "blmd/ident/evidence.h"
#include "blmd/io/csv.h"
#include "blmd/sim/effects.h"
#include "ident/counting_cost.h"
#include "parallel.h"

namespace blmd {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

// A candidate's search set-up: free effect parameters with bounds, fixed ones, start points.
struct CandidatePlan {
  std::string effect;
  bool applicable = true;
  std::string not_applicable;
  std::vector<FreeParameter> free;                                // the effect's free parameters
  std::map<std::string, double> fixed;                            // the effect's fixed parameters
  std::vector<std::vector<double>> starts;                        // start values for `free`
  std::vector<std::map<std::string, double>> fixed_alternatives;  // cogging: one per period
  std::vector<std::vector<std::vector<double>>> alternative_starts;  // extra starts per alternative
  std::string amplitude;  // parameter that must differ from zero
  // Physical constraint on the refit's values (all parameters, model and effects): empty
  // when valid, else why not.
  std::function<std::string(const ParameterSet&)> constraint;
  std::string evidence;  // what chose the plan's set-up (cogging: the order), for the report
};

FreeParameter Free(const std::string& name, double lower, double upper, bool log_scale = false) {
  FreeParameter p;
  p.name = name;
  p.lower = lower;
  p.upper = upper;
  p.log_scale = log_scale;
  p.initial = log_scale ? std::sqrt(lower * upper) : 0.5 * (lower + upper);
  return p;
}

// The torque scale T that sizes the candidates' search boxes (docs/discovery.md §2): the
// largest torque the record shows. dc_servo and blmd: the motor torque at the largest
// simulated current. rigid_load: the drive torque Kt max|u|, or the current model's damping
// torque B max|w| at its fitted values (w simulated) if that is larger. The second matters
// when the shaft moves without a drive: on a coast-down (u = 0) it is the torque that
// decelerates the shaft at its top speed (J |dw/dt| of the J, B model), where Kt max|u| is
// 0 and every search box would collapse to [0, 1e-12]. The measured acceleration is not
// used: differentiated twice from a logged speed, its maximum is noise (12 N m against
// B max|w| = 0.42 N m on the flywheel coast-down of docs/real-data.md). Driven from rest,
// B |w| of the J, B model stays below Kt max|u| (its steady state is B w = Kt u), so the
// scale changes only for records that start faster than the drive holds.
double TorqueScale(const FitProblem& problem, const ResidualAnalysis& analysis,
                   const std::vector<double>& values) {
  const std::string model(problem.config().model->name());
  if (model == "rigid_load") {
    const ParameterSet p = problem.Parameters(values);
    return std::max({p.Get("Kt") * analysis.u_max, p.Get("B") * analysis.w_max, 1e-12});
  }
  const ParameterSet& p = problem.config().parameters;
  double per_amp = 1.0;
  if (model == "dc_servo") per_amp = p.Get("Kt");
  if (model == "blmd") per_amp = 1.5 * p.Get("Ke");
  return std::max(per_amp * analysis.i_max, 1e-12);
}

// Cogging is fitted with the measured angle (docs/discovery.md, "Cogging: the measured
// angle"): a cogging torque large enough to matter captures the simulated shaft in detents
// at low speed, so with the simulated angle the cost over (Tcog, phase, J, B) is rugged and
// a local fit stays wherever it starts (measured: a start 12 % off in Tcog and 0.4 rad in
// phase does not move). Evaluated at the measured angle, the cogging torque is a known
// function of time for given (Tcog, phase): the response is nearly linear in it and the cost
// smooth. Fits use it; scores (BIC, NRMSE, the report's errors) use the free-running model.
bool UsesMeasuredAngle(const Config& config) {
  return std::find(config.effects.begin(), config.effects.end(), "cogging") != config.effects.end();
}

FitProblem MakeProblem(const Config& config, const std::vector<FitTrace>& traces,
                       const std::vector<std::string>& observe,
                       const std::vector<FreeParameter>& free) {
  FitProblem problem(config, traces, observe, free);
  if (UsesMeasuredAngle(config)) problem.ForceEffectAngle();  // unchanged without theta or w
  return problem;
}

// The cost of the free-running model (the simulated angle everywhere) at `values`.
Evaluation FreeRunEvaluation(const FitProblem& problem, const std::vector<double>& values,
                             const Evaluation& evaluation) {
  if (!problem.effect_angle_forced()) return evaluation;
  const FitProblem free_run(problem.config(), problem.traces(), problem.observe(), problem.free());
  return free_run.Evaluate(values);
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
  if (problem.config().model->name() != "rigid_load") return ranked;
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
  const int min_order = std::max(1, static_cast<int>(std::ceil(3.0 * 2.0 * kPi / path)));
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

CandidatePlan Plan(const std::string& effect, const FitProblem& problem,
                   const ResidualAnalysis& analysis, const std::vector<double>& values) {
  CandidatePlan plan;
  plan.effect = effect;
  const double T = TorqueScale(problem, analysis, values);
  const double w_max = std::max(analysis.w_max, 1e-9);
  const auto& observe = problem.observe();
  const bool observes_i = std::find(observe.begin(), observe.end(), "i") != observe.end();
  if (effect == "coulomb_friction") {
    plan.free = {Free("Tc", 0.0, T)};
    for (double f : {0.003, 0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * T});
    plan.amplitude = "Tc";
  } else if (effect == "load_torque") {
    plan.free = {Free("TL", -T, T)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) {
      plan.starts.push_back({f * T});
      plan.starts.push_back({-f * T});
    }
    plan.amplitude = "TL";
  } else if (effect == "quadratic_drag") {
    const double scale = T / (w_max * w_max);
    plan.free = {Free("Cd", 0.0, scale)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) plan.starts.push_back({f * scale});
    plan.amplitude = "Cd";
  } else if (effect == "asymmetric_viscous") {
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
  } else if (effect == "stribeck") {
    plan.free = {Free("Ts", 0.0, T), Free("ws", 1e-3 * w_max, w_max, true)};
    for (double f : {0.01, 0.03, 0.1, 0.3}) {
      for (double g : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * T, g * w_max});
    }
    plan.amplitude = "Ts";
  } else if (effect == "cogging") {
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
      for (const char* column : {"w", "theta", "i"}) {
        for (const auto& d : analysis.columns) {
          if (d.column != column) continue;
          for (const auto& peak : d.angle_peaks) {
            if (orders.size() < 4 &&
                std::find(orders.begin(), orders.end(), peak.order) == orders.end()) {
              orders.push_back(peak.order);
            }
          }
        }
      }
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
  } else if (effect == "dead_time") {
    const double u_max = std::max(analysis.u_max, 1e-9);
    plan.free = {Free("Vdt", 0.0, 0.5 * u_max)};
    for (double f : {0.003, 0.01, 0.03, 0.1}) plan.starts.push_back({f * u_max});
    plan.amplitude = "Vdt";
  } else if (effect == "current_offset") {
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
  } else {
    plan.applicable = false;
    plan.not_applicable = "no discovery plan for this effect";
  }
  return plan;
}

struct CandidateRun {
  CandidateOutcome outcome;
  Config config;
  std::vector<FreeParameter> free;
  FitResult fit;
  std::map<std::string, double> fixed;
  std::vector<double> screen_values;  // after the scan and one Gauss-Newton step
  double screen_bic = std::numeric_limits<double>::infinity();  // delta BIC at screening
  bool refitted = false;
};

// Builds the problem with `effect` added at `effect_values` (free) and `fixed`.
FitProblem CandidateProblem(const FitProblem& base, const std::vector<double>& base_values,
                            const CandidatePlan& plan, const std::vector<double>& effect_values,
                            const std::map<std::string, double>& fixed, Config* config_out,
                            std::vector<FreeParameter>* free_out) {
  Config config = base.config();
  ParameterSet effect_parameters;
  for (std::size_t k = 0; k < plan.free.size(); ++k)
    effect_parameters.Set(plan.free[k].name, effect_values[k]);
  for (const auto& [name, value] : fixed) effect_parameters.Set(name, value);
  config.AddEffect(plan.effect, effect_parameters);
  std::vector<FreeParameter> free = base.free();
  for (std::size_t k = 0; k < free.size(); ++k) {
    free[k].initial = std::clamp(base_values[k], free[k].lower, free[k].upper);
    config.parameters.Set(free[k].name, free[k].initial);
  }
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    FreeParameter p = plan.free[k];
    p.initial = std::clamp(effect_values[k], p.lower, p.upper);
    free.push_back(p);
  }
  *config_out = config;
  *free_out = free;
  return MakeProblem(config, base.traces(), base.observe(), free);
}

// Cost of a candidate problem at values given in physical units, in search coordinates
// (log for log-scale parameters).
std::vector<double> ToSearch(const FitProblem& problem, const std::vector<double>& values) {
  std::vector<double> x(values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    x[k] = problem.free()[k].log_scale ? std::log(values[k]) : values[k];
  }
  return x;
}
std::vector<double> FromSearch(const FitProblem& problem, const std::vector<double>& x) {
  std::vector<double> values(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const FreeParameter& p = problem.free()[k];
    values[k] = std::clamp(p.log_scale ? std::exp(x[k]) : x[k], p.lower, p.upper);
  }
  return values;
}

// One damped Gauss-Newton step on all free parameters from `values` (the issue's "one-step
// Gauss-Newton fit"): cheap, and it lets J and B move with the new effect, which a scan with
// J and B held cannot. Returns the better of the start and the step.
std::pair<std::vector<double>, Evaluation> OneStepGaussNewton(const FitProblem& problem,
                                                              const std::vector<double>& values,
                                                              const Evaluation& start) {
  const std::size_t p = problem.num_free();
  std::vector<double> r0;
  if (!problem.Evaluate(values, &r0).ok) return {values, start};
  const std::size_t n = r0.size();
  const std::vector<double> x0 = ToSearch(problem, values);
  Eigen::MatrixXd jacobian(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(p));
  for (std::size_t k = 0; k < p; ++k) {
    const FreeParameter& fp = problem.free()[k];
    const double h =
        fp.log_scale ? 1e-3 : 1e-3 * std::max(std::abs(x0[k]), 1e-2 * (fp.upper - fp.lower));
    std::vector<double> xp = x0, xm = x0, rp, rm;
    xp[k] += h;
    xm[k] -= h;
    if (!problem.Evaluate(FromSearch(problem, xp), &rp).ok ||
        !problem.Evaluate(FromSearch(problem, xm), &rm).ok) {
      return {values, start};
    }
    for (std::size_t i = 0; i < n; ++i) {
      jacobian(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) =
          (rp[i] - rm[i]) / (2.0 * h);
    }
  }
  const Eigen::Map<const Eigen::VectorXd> residual(r0.data(), static_cast<Eigen::Index>(n));
  Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
  const Eigen::VectorXd gradient = jacobian.transpose() * residual;
  std::vector<double> best_values = values;
  Evaluation best = start;
  for (double damping : {1e-4, 1e-2, 1.0}) {
    Eigen::MatrixXd damped = normal;
    for (Eigen::Index k = 0; k < damped.rows(); ++k) damped(k, k) *= (1.0 + damping);
    const Eigen::VectorXd step = damped.ldlt().solve(-gradient);
    if (!step.allFinite()) continue;
    std::vector<double> x = x0;
    for (std::size_t k = 0; k < p; ++k) x[k] += step(static_cast<Eigen::Index>(k));
    const std::vector<double> trial = FromSearch(problem, x);
    const Evaluation evaluation = problem.Evaluate(trial);
    if (evaluation.ok && evaluation.cost < best.cost) {
      best = evaluation;
      best_values = trial;
      break;
    }
  }
  return {best_values, best};
}

// Screening: a deterministic scan of the effect's start points (and cogging periods) with
// the other parameters held, then one Gauss-Newton step on all of them.
CandidateRun ScreenCandidate(const FitProblem& base, const std::vector<double>& base_values,
                             const CandidatePlan& plan, double bic_before) {
  CandidateRun run;
  run.outcome.effect = plan.effect;
  if (!plan.applicable) {
    run.outcome.reason = plan.not_applicable;
    return run;
  }
  std::vector<std::map<std::string, double>> alternatives = plan.fixed_alternatives;
  if (alternatives.empty()) alternatives.push_back({});
  // Scan: every start point of every alternative, the other parameters held.
  struct Scanned {
    double cost;
    std::size_t alternative;
    std::vector<double> start;
  };
  std::vector<Scanned> scanned;
  for (std::size_t a = 0; a < alternatives.size(); ++a) {
    std::vector<std::vector<double>> starts = plan.starts;
    if (a < plan.alternative_starts.size()) {
      starts.insert(starts.begin(), plan.alternative_starts[a].begin(),
                    plan.alternative_starts[a].end());
    }
    Scanned best_of_alternative{std::numeric_limits<double>::infinity(), a, {}};
    std::vector<Scanned> of_alternative;
    for (const auto& start : starts) {
      Config config;
      std::vector<FreeParameter> free;
      const FitProblem problem =
          CandidateProblem(base, base_values, plan, start, alternatives[a], &config, &free);
      const Evaluation evaluation = problem.Evaluate(problem.InitialValues());
      if (evaluation.ok) of_alternative.push_back({evaluation.cost, a, start});
    }
    // With several alternatives (cogging orders) only each one's best start competes.
    std::stable_sort(of_alternative.begin(), of_alternative.end(),
                     [](const Scanned& l, const Scanned& r) { return l.cost < r.cost; });
    const std::size_t keep = alternatives.size() > 1 ? 1 : 2;
    for (std::size_t k = 0; k < of_alternative.size() && k < keep; ++k)
      scanned.push_back(of_alternative[k]);
  }
  if (scanned.empty()) {
    run.outcome.reason = "every start point failed to simulate";
    return run;
  }
  // The scan holds J and B at values that absorbed the missing effect, so its ranking is
  // rough: the best few (five alternatives, or the two best starts) each get a short local
  // search on all free parameters (BOBYQA; a short Ceres fit at the measured angle for
  // cogging), and the best of those is screened.
  std::stable_sort(scanned.begin(), scanned.end(),
                   [](const Scanned& l, const Scanned& r) { return l.cost < r.cost; });
  if (scanned.size() > 5) scanned.resize(5);
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> best_values;
  std::map<std::string, double> best_fixed;
  for (const auto& candidate : scanned) {
    Config config;
    std::vector<FreeParameter> free;
    const FitProblem problem =
        CandidateProblem(base, base_values, plan, candidate.start,
                         alternatives[candidate.alternative], &config, &free);
    double cost = std::numeric_limits<double>::infinity();
    std::vector<double> values;
    if (problem.effect_angle_forced()) {
      // At the measured angle the cost is smooth: a short Ceres fit settles each order.
      OptimizerOptions short_fit;
      short_fit.threads = 1;
      short_fit.method_options["max_iterations"] = 10;
      const FitResult fit = FindOptimizer("ceres").Minimize(problem, short_fit);
      if (fit.evaluation.ok) {
        cost = fit.evaluation.cost;
        values = fit.values;
      }
    } else {
      internal::CountingCost counting(problem);
      const internal::LocalResult local = internal::NloptLocal(
          counting, "bobyqa", problem.ToScaled(problem.InitialValues()), 0.05, 40, 1e-6, 1e-6);
      cost = local.cost;
      values = problem.FromScaled(local.scaled);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best_fixed = alternatives[candidate.alternative];
      best_values = values;
    }
  }
  if (best_values.empty()) {
    run.outcome.reason = "the local searches of the scan's best points failed";
    return run;
  }
  const std::vector<double> searched_base(best_values.begin(),
                                          best_values.begin() + static_cast<long>(base.num_free()));
  const std::vector<double> best_start(best_values.begin() + static_cast<long>(base.num_free()),
                                       best_values.end());
  const FitProblem problem =
      CandidateProblem(base, searched_base, plan, best_start, best_fixed, &run.config, &run.free);
  const Evaluation at_start = problem.Evaluate(problem.InitialValues());
  auto [values, fitted] = OneStepGaussNewton(problem, problem.InitialValues(), at_start);
  Evaluation evaluation = FreeRunEvaluation(problem, values, fitted);
  if (plan.effect == "cogging" && problem.effect_angle_forced() && evaluation.ok &&
      !(Bic(problem, evaluation, problem.num_free()) < bic_before)) {
    // Fitted at the measured angle, the point may sit just outside the free-running model's
    // narrow basin (a cogging torque captures the simulated shaft in other detents): a short
    // free-running search from there decides, as the refit's polish does.
    std::vector<FreeParameter> free = run.free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = values[k];
    const FitProblem free_run(run.config, base.traces(), base.observe(), free);
    OptimizerOptions polish;
    polish.threads = 1;
    polish.method_options["max_iterations"] = 10;
    const FitResult polished = FindOptimizer("ceres").Minimize(free_run, polish);
    if (polished.evaluation.ok && polished.evaluation.cost < evaluation.cost) {
      values = polished.values;
      evaluation = polished.evaluation;
    }
  }
  run.fixed = best_fixed;
  run.screen_values = values;
  run.screen_bic = Bic(problem, evaluation, problem.num_free()) - bic_before;
  run.outcome.delta_bic = run.screen_bic;
  run.outcome.nrmse = std::sqrt(evaluation.cost);
  return run;
}

// Full refit (Ceres, all free parameters) from the screening point, and the verdict.
// What every candidate of a round is compared with, computed once per round: the current
// model's residuals on the fit traces (for the prewhitened evidence) or its error on the
// held-out traces (for the held-out rule).
struct RoundBase {
  std::vector<double> residuals;  // empty when its evaluation failed
  Evaluation held_out;            // ok only with held-out traces that simulate
};

RoundBase MakeRoundBase(const FitProblem& base, const std::vector<double>& values,
                        const DiscoveryOptions& options) {
  RoundBase round;
  const bool held_out = options.held_out && !options.held_out->empty();
  if (!held_out && options.prewhiten && !base.Evaluate(values, &round.residuals).ok) {
    round.residuals.clear();
  }
  if (held_out) {
    std::vector<std::string> names;
    for (const auto& f : base.free()) names.push_back(f.name);
    const FitProblem held(base.config(), *options.held_out, base.observe(),
                          NamedFreeParameters(names));
    round.held_out = held.Evaluate(values);
  }
  return round;
}

void RefitCandidate(const FitProblem& base, const RoundBase& round, const CandidatePlan& plan,
                    double bic_before, const DiscoveryOptions& options, CandidateRun* run) {
  for (std::size_t k = 0; k < run->free.size(); ++k) run->free[k].initial = run->screen_values[k];
  const FitProblem problem = MakeProblem(run->config, base.traces(), base.observe(), run->free);
  OptimizerOptions refit = options.refit;
  if (!refit.method_options.contains("max_iterations")) refit.method_options["max_iterations"] = 50;
  run->fit = FindOptimizer("ceres").Minimize(problem, refit);
  if (run->fit.evaluation.ok && problem.effect_angle_forced()) {
    // Fitted at the measured angle: polish on the free-running model from there (its basin
    // is narrow but the measured-angle fit lands in it), keeping whichever runs better.
    std::vector<FreeParameter> free = run->free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = run->fit.values[k];
    const FitProblem free_run(run->config, base.traces(), base.observe(), free);
    const Evaluation at_forced = free_run.Evaluate(run->fit.values);
    OptimizerOptions polish = refit;
    polish.method_options["max_iterations"] = 20;
    FitResult polished = FindOptimizer("ceres").Minimize(free_run, polish);
    if (polished.evaluation.ok && (!at_forced.ok || polished.evaluation.cost < at_forced.cost)) {
      run->fit = std::move(polished);
    } else {
      run->fit.evaluation = at_forced;
    }
    // The screening point may already be a free-running search's result (ScreenCandidate)
    // that the measured-angle fit left: polish from it too and keep the better.
    const Evaluation at_screen = free_run.Evaluate(run->screen_values);
    if (at_screen.ok && at_screen.cost < run->fit.evaluation.cost) {
      for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = run->screen_values[k];
      const FitProblem from_screen(run->config, base.traces(), base.observe(), free);
      FitResult again = FindOptimizer("ceres").Minimize(from_screen, polish);
      if (again.evaluation.ok && again.evaluation.cost < run->fit.evaluation.cost)
        run->fit = std::move(again);
    }
  }
  run->outcome.fitted = run->fit.evaluation.ok;
  if (!run->outcome.fitted) {
    run->outcome.reason = "refit failed: " + run->fit.evaluation.reason;
    return;
  }
  run->outcome.bic = Bic(problem, run->fit.evaluation, problem.num_free());
  run->outcome.delta_bic = run->outcome.bic - bic_before;
  run->outcome.delta_bic_white = run->outcome.delta_bic;
  // The evidence counts what correlated samples are worth (evidence.h): the same change in
  // BIC on residuals whitened by the candidate model's AR noise model.
  // With held-out traces the evidence is theirs instead: the plain BIC on the fit traces,
  // and a lower error on traces the effect was not fitted to.
  run->outcome.evidence_rule = "plain_bic";
  if (options.held_out && !options.held_out->empty()) {
    std::vector<std::string> names;
    for (const auto& f : run->free) names.push_back(f.name);
    const FitProblem held_candidate(run->config, *options.held_out, base.observe(),
                                    NamedFreeParameters(names));
    const Evaluation after = held_candidate.Evaluate(run->fit.values);
    run->outcome.evidence_rule = "held_out";
    run->outcome.has_held_out = round.held_out.ok && after.ok;
    if (run->outcome.has_held_out) {
      run->outcome.held_out_before = std::sqrt(round.held_out.cost);
      run->outcome.held_out_after = std::sqrt(after.cost);
      run->outcome.held_out_better = run->outcome.held_out_after <
                                     (1.0 - options.held_out_margin) * run->outcome.held_out_before;
    } else {
      run->outcome.held_out_better = false;
    }
  } else if (options.prewhiten && !round.residuals.empty()) {
    const FitProblem model(run->config, base.traces(), base.observe(), run->free);
    const WhitenedEvidence evidence =
        PrewhitenedEvidence(round.residuals, base.num_free(), model, run->fit.values);
    if (evidence.ok) {
      run->outcome.evidence_rule = "prewhitened_bic";
      run->outcome.delta_bic = evidence.delta_bic;
      run->outcome.bic = bic_before + evidence.delta_bic;
      for (std::size_t c = 0; c < base.observe().size(); ++c) {
        run->outcome.noise_model[base.observe()[c]] = {evidence.order[c],
                                                       evidence.innovation_ratio[c]};
      }
    }
  }
  run->outcome.nrmse = std::sqrt(run->fit.evaluation.cost);
  const std::size_t offset = base.num_free();
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    run->outcome.parameters[plan.free[k].name] = run->fit.values[offset + k];
  }
  for (const auto& [name, value] : run->fixed) run->outcome.parameters[name] = value;
  for (std::size_t k = 0; k < run->free.size() && k < run->fit.values.size(); ++k) {
    run->outcome.model_parameters[run->free[k].name] = run->fit.values[k];
  }
  // Physical validity: off the search bounds, and the amplitude distinguishable from zero.
  run->outcome.valid = true;
  for (std::size_t k = 0; k < plan.free.size(); ++k) {
    const FreeParameter& p = plan.free[k];
    if (p.name == "phase") continue;  // periodic
    const double v = run->fit.values[offset + k];
    const double margin = 1e-3 * (p.log_scale ? std::log(p.upper / p.lower) : (p.upper - p.lower));
    const double below = p.log_scale ? std::log(v / p.lower) : v - p.lower;
    const double above = p.log_scale ? std::log(p.upper / v) : p.upper - v;
    if (below < margin || above < margin) {
      run->outcome.valid = false;
      run->outcome.reason = p.name + " = " + G(v) + " sits on its search bound [" + G(p.lower) +
                            ", " + G(p.upper) + "]";
      break;
    }
    if (p.name == plan.amplitude) {
      const ParameterEstimate& e = run->fit.estimates[offset + k];
      if (e.has_interval && std::abs(v) < 2.0 * e.std) {
        run->outcome.valid = false;
        run->outcome.reason =
            p.name + " = " + G(v) + " is within two standard deviations (" + G(e.std) + ") of zero";
        break;
      }
    }
  }
  if (run->outcome.valid && plan.constraint) {
    ParameterSet values = run->config.parameters;
    for (std::size_t k = 0; k < run->free.size(); ++k)
      values.Set(run->free[k].name, run->fit.values[k]);
    if (std::string why = plan.constraint(values); !why.empty()) {
      run->outcome.valid = false;
      run->outcome.reason = why;
    }
  }
  if (run->outcome.valid && !(run->outcome.delta_bic < -options.bic_margin)) {
    run->outcome.reason = "BIC does not fall by more than " + G(options.bic_margin);
  } else if (run->outcome.valid && !run->outcome.held_out_better) {
    run->outcome.reason = run->outcome.has_held_out
                              ? "the held-out NRMSE does not fall by more than " +
                                    G(100.0 * options.held_out_margin) + " % (" +
                                    G(run->outcome.held_out_before) + " -> " +
                                    G(run->outcome.held_out_after) + ")"
                              : "the held-out traces could not be simulated with the effect";
  }
}

std::string Evidence(const std::string& effect, const ResidualAnalysis& analysis,
                     const CandidateOutcome& outcome, double nrmse_before) {
  std::string text =
      "BIC " + G(outcome.delta_bic, 5) +
      (outcome.evidence_rule == "prewhitened_bic" &&
               G(outcome.delta_bic_white, 5) != G(outcome.delta_bic, 5)
           ? " on whitened residuals (" + G(outcome.delta_bic_white, 5) + " counting every sample)"
           : std::string()) +
      ", NRMSE " + G(nrmse_before) + " -> " + G(outcome.nrmse) +
      (outcome.has_held_out
           ? ", held-out NRMSE " + G(outcome.held_out_before) + " -> " + G(outcome.held_out_after)
           : std::string());
  // The diagnostic that points at this effect, from the column where it is strongest.
  const ColumnDiagnostics* strongest = nullptr;
  auto pick = [&](auto score) {
    for (const auto& d : analysis.columns) {
      if (score(d) > 0.0 && (!strongest || score(d) > score(*strongest))) strongest = &d;
    }
  };
  if (effect == "coulomb_friction" || effect == "stribeck" || effect == "asymmetric_viscous") {
    pick([](const ColumnDiagnostics& d) {
      return d.sign_w.available ? std::abs(d.sign_w.t_statistic) : 0.0;
    });
    if (strongest)
      text += "; " + strongest->column +
              " residual mean differs by sign of w (t = " + G(strongest->sign_w.t_statistic, 3) +
              ")";
  } else if (effect == "dead_time") {
    pick([](const ColumnDiagnostics& d) {
      return d.sign_i.available ? std::abs(d.sign_i.t_statistic) : 0.0;
    });
    if (strongest)
      text += "; " + strongest->column +
              " residual mean differs by sign of i (t = " + G(strongest->sign_i.t_statistic, 3) +
              ")";
  } else if (effect == "cogging") {
    pick([](const ColumnDiagnostics& d) {
      return d.angle_peaks.empty() ? 0.0 : d.angle_peaks.front().ratio;
    });
    if (strongest) {
      text += "; " + strongest->column + " residual peaks at " +
              std::to_string(strongest->angle_peaks.front().order) + " periods/rev (" +
              G(strongest->angle_peaks.front().ratio, 3) + " x the spectrum's median)";
    }
  } else {
    pick([](const ColumnDiagnostics& d) { return d.rms > 0.0 ? std::abs(d.mean) / d.rms : 0.0; });
    if (strongest)
      text += "; " + strongest->column + " residual mean " + G(strongest->mean) + " (rms " +
              G(strongest->rms) + ")";
  }
  return text;
}

}  // namespace

double Bic(const FitProblem& problem, const Evaluation& evaluation, std::size_t k) {
  double bic = 0.0;
  std::size_t total = 0;
  for (std::size_t c = 0; c < problem.observe().size(); ++c) {
    std::size_t n = 0;
    for (std::size_t t = 0; t < problem.traces().size(); ++t) n += problem.measured(t).rows();
    total += n;
    // An MSE below 1e-12 of the column's variance (NRMSE 1e-6) is the simulator's numerical
    // precision, not a better fit: without this floor a noise-free trace's residual of
    // rounding errors let any effect "explain" part of it (a current offset of 1e-12 A).
    const double floor = std::max(1e-12 * problem.variance()[c], 1e-300);
    bic += static_cast<double>(n) * std::log(std::max(evaluation.mse[c], floor));
  }
  return bic + static_cast<double>(k) * std::log(static_cast<double>(total));
}

DiscoveryResult Discover(const FitProblem& problem, const FitResult& initial,
                         const DiscoveryOptions& options) {
  DiscoveryResult result;
  std::vector<std::string> candidates = options.candidates;
  const std::string model(problem.config().model->name());
  if (candidates.empty()) {
    for (const auto& effect : EffectRegistry()) {
      if (std::find(effect.models.begin(), effect.models.end(), model) != effect.models.end()) {
        candidates.push_back(effect.name);
      }
    }
  }
  // The current model: problem + fit.
  auto current_problem = std::make_unique<FitProblem>(problem);
  FitResult current_fit = initial;
  double current_bic = initial.evaluation.ok ? Bic(problem, initial.evaluation, problem.num_free())
                                             : std::numeric_limits<double>::infinity();
  result.bic_initial = current_bic;
  if (!initial.evaluation.ok) {
    result.conclusion = "the initial fit failed: nothing to examine";
    result.final_config = problem.config();
    result.final_fit = initial;
    return result;
  }
  for (int round = 0; round < options.max_effects; ++round) {
    const ResidualAnalysis analysis = AnalyseResidual(*current_problem, current_fit.values);
    std::vector<CandidatePlan> plans;
    for (const auto& effect : candidates) {
      const auto& declared = current_problem->config().effects;
      if (std::find(declared.begin(), declared.end(), effect) != declared.end()) continue;
      plans.push_back(Plan(effect, *current_problem, analysis, current_fit.values));
    }
    if (plans.empty()) break;
    std::vector<CandidateRun> runs(plans.size());
    const int threads = internal::ThreadCount(options.refit.threads);
    auto parallel = [&](const std::vector<std::size_t>& items,
                        const std::function<void(std::size_t)>& work) {
      internal::ParallelFor(items.size(), threads, [&](std::size_t k) { work(items[k]); });
    };
    std::vector<std::size_t> all(plans.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = k;
    parallel(all, [&](std::size_t k) {
      runs[k] = ScreenCandidate(*current_problem, current_fit.values, plans[k], current_bic);
    });
    // Refit the most promising candidates by their screening BIC (deterministic order).
    // Only candidates whose screening already lowers BIC are worth a full refit.
    std::vector<std::size_t> screened;
    for (std::size_t k = 0; k < runs.size(); ++k) {
      if (!runs[k].screen_values.empty() && runs[k].screen_bic < 0.0) screened.push_back(k);
    }
    std::stable_sort(screened.begin(), screened.end(), [&](std::size_t l, std::size_t r) {
      return runs[l].screen_bic < runs[r].screen_bic;
    });
    if (screened.size() > static_cast<std::size_t>(options.refits))
      screened.resize(static_cast<std::size_t>(options.refits));
    const RoundBase round_base = MakeRoundBase(*current_problem, current_fit.values, options);
    parallel(screened, [&](std::size_t k) {
      RefitCandidate(*current_problem, round_base, plans[k], current_bic, options, &runs[k]);
      runs[k].refitted = true;
    });
    for (auto& run : runs) {
      if (!run.refitted && !run.screen_values.empty()) {
        run.outcome.reason = run.screen_bic >= 0.0
                                 ? "screened out: one Gauss-Newton step does not lower BIC (" +
                                       G(run.screen_bic, 4) + ")"
                                 : "screened out (one-step BIC " + G(run.screen_bic, 4) +
                                       "; only the best " + std::to_string(options.refits) +
                                       " are refit)";
      }
    }
    // Best first: fitted before not, then by BIC; ties by name (deterministic).
    std::vector<std::size_t> order(runs.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t l, std::size_t r) {
      const auto& a = runs[l].outcome;
      const auto& b = runs[r].outcome;
      if (a.fitted != b.fitted) return a.fitted;
      if (a.fitted && a.bic != b.bic) return a.bic < b.bic;
      if (!a.fitted && runs[l].screen_bic != runs[r].screen_bic)
        return runs[l].screen_bic < runs[r].screen_bic;
      return a.effect < b.effect;
    });
    std::vector<CandidateOutcome> outcomes;
    for (std::size_t k : order) outcomes.push_back(runs[k].outcome);
    std::vector<std::size_t> qualifying;
    for (std::size_t k : order) {
      const auto& o = runs[k].outcome;
      if (o.fitted && o.valid && o.held_out_better && o.delta_bic < -options.bic_margin)
        qualifying.push_back(k);
    }
    if (qualifying.empty()) {
      result.last_round = outcomes;
      break;
    }
    const CandidateRun& best = runs[qualifying.front()];
    std::vector<std::string> tied = {best.outcome.effect};
    for (std::size_t q = 1; q < qualifying.size(); ++q) {
      if (runs[qualifying[q]].outcome.bic - best.outcome.bic < options.ambiguity_margin) {
        tied.push_back(runs[qualifying[q]].outcome.effect);
      }
    }
    if (tied.size() > 1) {
      // Listed by name: which of equals comes first carries no information.
      std::sort(tied.begin(), tied.end());
      result.ambiguous.push_back(tied);
      std::string names;
      for (const auto& n : tied) names += (names.empty() ? "" : " and ") + n;
      result.ambiguity_reason =
          names + " explain the residual equally well (BIC within " + G(options.ambiguity_margin) +
          ")" +
          (analysis.w_changes_sign ? ""
                                   : "; w never changes sign on this data, "
                                     "so friction and a constant load look alike") +
          ": record motion in both directions to tell them apart";
      result.last_round = outcomes;
      break;
    }
    DiscoveryStep step;
    step.effect = best.outcome.effect;
    step.nrmse_before = std::sqrt(current_fit.evaluation.cost);
    step.nrmse_after = best.outcome.nrmse;
    step.bic_before = current_bic;
    step.bic_after = best.outcome.bic;
    step.candidates = outcomes;
    step.fixed_parameters = best.fixed;
    const std::size_t offset = current_problem->num_free();
    for (std::size_t k = offset; k < best.fit.estimates.size(); ++k) {
      step.effect_parameters.push_back(best.fit.estimates[k]);
    }
    step.evidence = Evidence(step.effect, analysis, best.outcome, step.nrmse_before);
    if (!plans[qualifying.front()].evidence.empty())
      step.evidence += "; " + plans[qualifying.front()].evidence;
    result.steps.push_back(step);
    result.added.push_back(step.effect);
    // The winner becomes the current model, its fitted values its parameters.
    Config config = best.config;
    for (std::size_t k = 0; k < best.free.size(); ++k)
      config.parameters.Set(best.free[k].name, best.fit.values[k]);
    std::vector<FreeParameter> free = best.free;
    for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = best.fit.values[k];
    current_problem = std::make_unique<FitProblem>(
        MakeProblem(config, problem.traces(), problem.observe(), free));
    current_fit = best.fit;
    current_bic = best.outcome.bic;
  }
  result.final_config = current_problem->config();
  for (const auto& p : current_problem->free()) result.final_free.push_back(p.name);
  result.final_free_parameters = current_problem->free();
  result.final_fit = current_fit;
  if (!result.ambiguous.empty() && result.added.empty()) {
    result.conclusion = "ambiguous: " + result.ambiguity_reason;
  } else if (result.added.empty()) {
    std::string best;
    if (!result.last_round.empty() && result.last_round.front().fitted) {
      best = " (best candidate " + result.last_round.front().effect + ": BIC " +
             G(result.last_round.front().delta_bic, 4) + ")";
    }
    result.conclusion = "nothing missing: no effect lowers BIC by more than " +
                        G(options.bic_margin) + " with valid parameters" + best;
  } else {
    std::string names;
    for (const auto& n : result.added) names += (names.empty() ? "" : ", ") + n;
    result.conclusion = "added " + names;
    if (!result.ambiguous.empty())
      result.conclusion += "; then ambiguous: " + result.ambiguity_reason;
  }
  return result;
}

std::unique_ptr<FitProblem> FinalProblem(const FitProblem& problem, const DiscoveryResult& result) {
  if (result.added.empty()) return nullptr;
  // The bounds discovery fitted the effects in (their search boxes), the values as start.
  std::vector<FreeParameter> free = result.final_free_parameters;
  if (free.size() != result.final_fit.values.size()) return nullptr;
  for (std::size_t k = 0; k < free.size(); ++k) free[k].initial = result.final_fit.values[k];
  return std::make_unique<FitProblem>(result.final_config, problem.traces(), problem.observe(),
                                      std::move(free));
}

}  // namespace blmd
