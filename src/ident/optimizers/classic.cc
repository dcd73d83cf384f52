// The classical estimators of Ganesh et al. (2012), Sec. II (docs/identification.md):
//   Kb = slope of Eb = u - R i against w over steady-state points (eqs. 1-2), Kt = Kb (eq. 5);
//   B  = Kt i / w at steady state (eq. 8), least squares over the steady plateaus;
//   J  = B tau, tau the time the coast-down speed takes to fall to 36.8 % (eqs. 9-11).
// They assume no Coulomb friction; with it the coast-down is not exponential and J = B tau
// is biased (the report's `notes` says which estimators applied).
#include <algorithm>
#include <chrono>
#include <cmath>

#include "blmd/error.h"
#include "ident/fit/counting_cost.h"
#include "ident/optimizers/methods.h"

namespace blmd::internal {
namespace {

struct Plateau {
  double u = 0.0, i = 0.0, w = 0.0;
  double end_time = 0.0;
};

// Segments of constant u (closed armature) at least `min_samples` long; each plateau's
// steady values are the means over its last `tail` fraction.
std::vector<Plateau> FindPlateaus(const Trace& trace, std::size_t end, double tail) {
  std::vector<Plateau> plateaus;
  const auto& t = trace.Column("t");
  const auto& u = trace.Column("u");
  const auto& i = trace.Column("i");
  const auto& w = trace.Column("w");
  double u_scale = 0.0;
  for (double v : u) u_scale = std::max(u_scale, std::abs(v));
  const double tolerance = 1e-9 * std::max(u_scale, 1e-12);
  std::size_t start = 0;
  for (std::size_t k = 1; k <= end; ++k) {
    if (k == end || std::abs(u[k] - u[start]) > tolerance) {
      const std::size_t length = k - start;
      if (length >= 20 && std::abs(u[start]) > tolerance) {
        const std::size_t from =
            k -
            std::max<std::size_t>(2, static_cast<std::size_t>(tail * static_cast<double>(length)));
        Plateau p;
        p.u = u[start];
        for (std::size_t r = from; r < k; ++r) {
          p.i += i[r];
          p.w += w[r];
        }
        p.i /= static_cast<double>(k - from);
        p.w /= static_cast<double>(k - from);
        p.end_time = t[k - 1];
        plateaus.push_back(p);
      }
      start = k;
    }
  }
  return plateaus;
}

}  // namespace

std::vector<std::string> ClassicOptimizer::option_names() const { return {"tail"}; }

FitResult ClassicOptimizer::Minimize(const FitProblem& problem,
                                     const OptimizerOptions& options) const {
  CheckMethodOptions("classic", options.method_options, option_names());
  const double tail =
      OptionNumber("classic", options.method_options, "tail", 0.1, {0.0, 1.0, true});
  const auto started = std::chrono::steady_clock::now();
  const Config& config = problem.config();
  if (!config.model->traits().classic_estimators) {
    throw InputError("method classic applies to dc_servo traces (steady state and coast-down)");
  }
  const double R = config.parameters.Get("R");
  double Kt = config.parameters.Get("Kt");
  std::vector<Plateau> plateaus;
  std::vector<double> taus, tau_B;  // coast-down time constants and the B before each
  std::vector<std::string> notes;
  for (const auto& fit_trace : problem.traces()) {
    const Trace& trace = fit_trace.trace;
    for (const char* column : {"i", "w"}) {
      if (!trace.Has(column)) {
        throw InputError(fit_trace.path + ": method classic needs column '" + column + "'");
      }
    }
    const auto& t = trace.Column("t");
    const auto& w = trace.Column("w");
    const auto& i = trace.Column("i");
    // Coast-down start: the `open` column, else the instant the current falls to zero for good.
    std::size_t off = t.size();
    if (trace.Has("open")) {
      const auto& open = trace.Column("open");
      for (std::size_t k = 0; k < open.size(); ++k) {
        if (open[k] != 0.0) {
          off = k;
          break;
        }
      }
    } else {
      double i_max = 0.0;
      for (double v : i) i_max = std::max(i_max, std::abs(v));
      std::size_t last_on = 0;
      for (std::size_t k = 0; k < i.size(); ++k) {
        if (std::abs(i[k]) > 0.02 * i_max) last_on = k;
      }
      if (last_on + 10 < i.size() && i_max > 0.0) off = last_on + 1;
    }
    const auto found = FindPlateaus(trace, off, tail);
    plateaus.insert(plateaus.end(), found.begin(), found.end());
    if (off < t.size() && !found.empty()) {
      const Plateau& before = found.back();
      // w0: the steady speed at the opening (plateau mean, robust to noise). The 36.8 %
      // instant is located by a least-squares line through the samples within +-3 % of
      // w0 around the first crossing, so measurement noise averages out.
      const double w0 = before.w;
      const double t_off = t[off];
      const double target = 0.368 * w0;
      const double band = 0.03 * std::abs(w0);
      std::size_t first_cross = t.size();
      for (std::size_t k = off; k < t.size(); ++k) {
        if ((w0 > 0.0 && w[k] <= target) || (w0 < 0.0 && w[k] >= target)) {
          first_cross = k;
          break;
        }
      }
      if (first_cross < t.size()) {
        double st = 0.0, sw = 0.0, stt = 0.0, stw = 0.0;
        long n = 0;
        for (std::size_t k = off; k < t.size(); ++k) {
          if (std::abs(w[k] - target) <= band) {
            st += t[k];
            sw += w[k];
            stt += t[k] * t[k];
            stw += t[k] * w[k];
            ++n;
          }
        }
        double t_cross = t[first_cross];
        const double denominator = static_cast<double>(n) * stt - st * st;
        if (n >= 3 && denominator > 0.0) {
          const double slope = (static_cast<double>(n) * stw - st * sw) / denominator;
          const double intercept = (sw - slope * st) / static_cast<double>(n);
          if (slope != 0.0) t_cross = (target - intercept) / slope;
        }
        taus.push_back(t_cross - t_off);
        tau_B.push_back(before.w != 0.0 ? before.i / before.w : 0.0);  // times Kt later
      }
    }
  }
  if (plateaus.empty()) {
    throw InputError("method classic found no steady-state plateau (constant u held long enough)");
  }
  FitResult result;
  // Kb from the Eb-w slope when there are at least two distinct plateaus.
  double sum_ew = 0.0, sum_ww = 0.0, sum_iw = 0.0;
  for (const auto& p : plateaus) {
    sum_ew += (p.u - R * p.i) * p.w;
    sum_ww += p.w * p.w;
    sum_iw += p.i * p.w;
  }
  if (plateaus.size() >= 2 && sum_ww > 0.0) {
    const double Kb = sum_ew / sum_ww;
    Kt = Kb;  // eq. 5, SI units
    result.extra_estimates["Kb"] = Kb;
    result.extra_estimates["Kt"] = Kt;
    notes.push_back("Kb from the Eb-w slope over " + std::to_string(plateaus.size()) +
                    " plateaus; Kt = Kb");
  } else {
    notes.push_back("one plateau: Kt taken from the config");
  }
  const double B = sum_ww > 0.0 ? Kt * sum_iw / sum_ww : 0.0;
  double J = 0.0;
  if (!taus.empty()) {
    double sum = 0.0;
    for (std::size_t k = 0; k < taus.size(); ++k) sum += Kt * tau_B[k] * taus[k];
    J = sum / static_cast<double>(taus.size());
    notes.push_back("J = B tau from " + std::to_string(taus.size()) + " coast-down(s)");
  } else {
    notes.push_back("no coast-down found: J keeps its initial value (not estimated)");
  }
  std::vector<double> values = problem.InitialValues();
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    const std::string& name = problem.free()[k].name;
    if (name == "B" && B > 0.0) values[k] = B;
    if (name == "J" && J > 0.0) values[k] = J;
    if (name == "Kt" || name == "Kb") values[k] = Kt;
  }
  result.values = values;
  result.evaluation = problem.Evaluate(values);
  if (options.progress) options.progress->Evaluated(result.evaluation.cost);  // summary: 1
  result.estimates = MakeEstimates(problem, values);
  OptimizerSummary& summary = result.summary;
  summary.method = "classic";
  summary.algorithm = "Ganesh et al. (2012) steady-state and 36.8 % coast-down estimators";
  bool j_free = false;
  for (const auto& p : problem.free()) j_free = j_free || p.name == "J";
  // Converged only when every free parameter it can estimate was estimated: J needs a
  // coast-down, B a plateau with the shaft turning.
  summary.converged = result.evaluation.ok && B > 0.0 && (!j_free || J > 0.0);
  summary.termination = "closed form";
  summary.message = "estimated from " + std::to_string(plateaus.size()) + " plateau(s) and " +
                    std::to_string(taus.size()) + " coast-down(s)";
  summary.iterations = 1;
  summary.evaluations = 1;
  summary.figures = ClassicFigures{notes, taus, plateaus.size()};
  summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

}  // namespace blmd::internal
