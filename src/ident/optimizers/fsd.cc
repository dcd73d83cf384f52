// Fast Simulated Diffusion, reconstructed from its public foundations (docs/fsd.md):
//  - simulated diffusion (Geman & Hwang 1986): dx = -grad U dt + sqrt(2 T(t)) dW with
//    reflecting boundaries and a logarithmic cooling T(t) = c / ln(2 + t);
//  - its discrete form (Gelfand & Mitter 1991): x_{k+1} = x_k - a (grad U + xi_k) + b_k W_k,
//    xi_k the error of a finite-difference gradient, b_k = sqrt(2 a T_k);
//  - "fast" (Sakurai, Lin & Newton 1992, as described by Guinee & Lyden): deterministic
//    local descent (a quench, here a short BOBYQA) after each diffusion burst, so little
//    time is spent wandering inside one basin, and a final local polish of the best points
//    (each walker's best and the best probe; the lowest result wins).
// Everything works in the unit cube of scaled coordinates; the cost is normalised by its
// spread over a few random probe points, so temperatures and steps are problem-free
// numbers. Each walker owns a random stream derived from (seed, walker), so results do not
// depend on the number of threads.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "blmd/ident/fit/surface.h"
#include "blmd/random.h"
#include "ident/fit/counting_cost.h"
#include "ident/optimizers/methods.h"
#include "parallel.h"

namespace blmd::internal {
namespace {

struct FsdSettings {
  int walkers = 4;               // independent diffusions (the first starts at the initial point)
  int bursts = 6;                // diffusion bursts per walker, each followed by a quench
  int burst_steps = 8;           // Langevin steps per burst
  int quench_evaluations = 30;   // BOBYQA evaluations per quench
  double quench_step = 0.03;     // scaled units, BOBYQA initial step in a quench
  int probes = 0;                // random probe points for the cost scale (0: 8 per parameter)
  double initial_spread = 0.15;  // scaled units: sqrt(2 a T0) at the first step
  double t0 = 1.0;               // initial temperature in units of the probe spread
  double fd_step = 1e-3;         // scaled units, forward-difference gradient step
  double max_step = 0.2;         // scaled units, cap on one move per coordinate
  bool polish = true;            // final BOBYQA from each walker's best point and the best probe
  int polish_evaluations = 120;  // per polished point
  // BOBYQA's initial trust radius in the polish (scaled units). Large enough for its
  // quadratic model to see past the ripples of a rugged valley floor: measured on the BLMD
  // current cost, 0.1 follows the J-B valley to the global minimum where 0.02 stalls.
  double polish_step = 0.1;
};

double Reflect(double x) {
  // Reflecting boundary on [0, 1].
  for (int k = 0; k < 4 && (x < 0.0 || x > 1.0); ++k) {
    if (x < 0.0) x = -x;
    if (x > 1.0) x = 2.0 - x;
  }
  return std::clamp(x, 0.0, 1.0);
}

struct Walker {
  std::vector<double> x;
  double cost = std::numeric_limits<double>::infinity();
  std::vector<double> best_x;
  double best = std::numeric_limits<double>::infinity();
  long steps = 0;
};

class FsdRun {
 public:
  FsdRun(CountingCost& cost, const FsdSettings& s, double scale)
      : cost_(cost), s_(s), scale_(scale) {}

  // Normalised cost (divided by the probe spread); +inf stays +inf.
  // Each walker counts its own evaluations (thread_local: a walker runs on one thread), so
  // a budget stops every walker at the same point of its own schedule whatever the threads.
  static thread_local long walker_evaluations;
  double U(const std::vector<double>& x) {
    ++walker_evaluations;
    return cost_.ScaledCost(x) / scale_;
  }

  // Forward-difference gradient at x (cost at x known), stepping inward at the boundary; the
  // n displaced points are evaluated together (CountingCost::ScaledCosts).
  std::vector<double> Gradient(const std::vector<double>& x, double ux) {
    std::vector<double> g(x.size(), 0.0), h(x.size());
    std::vector<std::vector<double>> displaced(x.size(), x);
    for (std::size_t k = 0; k < x.size(); ++k) {
      h[k] = x[k] + s_.fd_step <= 1.0 ? s_.fd_step : -s_.fd_step;
      displaced[k][k] += h[k];
    }
    walker_evaluations += static_cast<long>(x.size());
    const std::vector<double> costs = cost_.ScaledCosts(displaced);
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double uy = costs[k] / scale_;
      g[k] = std::isfinite(uy) && std::isfinite(ux) ? (uy - ux) / h[k] : 0.0;
    }
    return g;
  }

  void Consider(Walker& w, const std::vector<double>& x, double u) {
    if (u < w.best) {
      w.best = u;
      w.best_x = x;
    }
  }

  // Evaluation budget of each walker (0: none), checked at burst boundaries.
  long budget = 0;
  bool Exhausted() const { return budget > 0 && walker_evaluations >= budget; }

  void RunWalker(Walker& w, Random& random, double a) {
    walker_evaluations = 0;
    const std::size_t n = w.x.size();
    w.cost = U(w.x);
    Consider(w, w.x, w.cost);
    long k = 0;
    for (int burst = 0; burst < s_.bursts && !Exhausted(); ++burst) {
      // Diffusion burst at the current temperature.
      for (int step = 0; step < s_.burst_steps; ++step, ++k) {
        const double temperature = s_.t0 * std::log(2.0) / std::log(2.0 + static_cast<double>(k));
        const double noise = std::sqrt(2.0 * a * temperature);
        const std::vector<double> g = Gradient(w.x, w.cost);
        std::vector<double> y(n);
        for (std::size_t j = 0; j < n; ++j) {
          double move = -a * g[j] + noise * random.Normal();
          move = std::clamp(move, -s_.max_step, s_.max_step);
          y[j] = Reflect(w.x[j] + move);
        }
        const double uy = U(y);
        if (std::isfinite(uy)) {  // an infinite cost is a wall: stay
          w.x = y;
          w.cost = uy;
          Consider(w, y, uy);
        }
      }
      // Quench: a short deterministic local descent (BOBYQA) from the walker's position.
      std::vector<double> x = w.x;
      double ux = w.cost;
      if (std::isfinite(ux) && s_.quench_evaluations > 0) {
        const LocalResult quench =
            NloptLocal(cost_, "bobyqa", w.x, s_.quench_step, s_.quench_evaluations, 1e-6, 1e-6);
        const double uq = quench.cost / scale_;
        if (uq < ux) {
          x = quench.scaled;
          ux = uq;
        }
      }
      Consider(w, x, ux);
    }
    w.steps = k;
  }

 private:
  CountingCost& cost_;
  const FsdSettings& s_;
  double scale_;
};

thread_local long FsdRun::walker_evaluations = 0;

// The method options (docs/identification.md, fsd options: ranges; scaled units are
// fractions of the box).
FsdSettings ReadSettings(const nlohmann::json& o, std::size_t n) {
  FsdSettings s;
  const std::string m = "fsd";
  s.walkers = OptionWholeNumber(m, o, "walkers", s.walkers, 1, 1024);
  s.bursts = OptionWholeNumber(m, o, "bursts", s.bursts, 1, 100000);
  s.burst_steps = OptionWholeNumber(m, o, "burst_steps", s.burst_steps, 1, 100000);
  s.quench_evaluations =
      OptionWholeNumber(m, o, "quench_evaluations", s.quench_evaluations, 0, 1000000);
  s.quench_step = OptionNumber(m, o, "quench_step", s.quench_step, {0.0, 1.0, true});
  s.probes = OptionWholeNumber(m, o, "probes",
                               static_cast<int>(std::min<std::size_t>(8 * n, 100000)), 2, 100000);
  s.initial_spread = OptionNumber(m, o, "initial_spread", s.initial_spread, {0.0, 1.0, true});
  s.t0 = OptionNumber(m, o, "t0", s.t0, {0.0, 1e6, true});
  s.fd_step = OptionNumber(m, o, "fd_step", s.fd_step, {0.0, 0.5, true});
  s.max_step = OptionNumber(m, o, "max_step", s.max_step, {0.0, 1.0, true});
  s.polish = OptionWholeNumber(m, o, "polish", 1, 0, 1) != 0;
  s.polish_evaluations =
      OptionWholeNumber(m, o, "polish_evaluations", s.polish_evaluations, 1, 1000000);
  s.polish_step = OptionNumber(m, o, "polish_step", s.polish_step, {0.0, 1.0, true});
  s.probes = std::max(2, s.probes);
  return s;
}

// The schedule's evaluations, for the progress's time left: the probes, each walker's
// bursts (n + 1 per step, at most quench_evaluations per quench; a budget stops a walker at
// the end of the burst that spends it) and at most walkers + 1 polished points.
long ScheduledEvaluations(const FsdSettings& s, std::size_t n, long walker_budget) {
  const long burst = static_cast<long>(s.burst_steps) * static_cast<long>(n + 1) +
                     static_cast<long>(s.quench_evaluations);
  long per_walker = 1 + static_cast<long>(s.bursts) * burst;
  if (walker_budget > 0) per_walker = std::min(per_walker, walker_budget + burst);
  const long polish = s.polish ? static_cast<long>(s.walkers + 1) * s.polish_evaluations : 0;
  return s.probes + static_cast<long>(s.walkers) * per_walker + polish;
}

// The probes' costs, evaluated in shards (SIMD lanes for blmd); every probe's cost lands in
// its own slot, so the result does not depend on the thread count.
std::vector<double> ProbeCosts(CountingCost& cost, const std::vector<std::vector<double>>& probes,
                               int threads) {
  std::vector<double> probe_cost(probes.size());
  ParallelFor(static_cast<std::size_t>(threads), threads, [&](std::size_t shard) {
    const auto [begin, end] = ShardRange(probes.size(), static_cast<int>(shard) + 1, threads);
    const std::vector<double> costs = cost.ScaledCosts(
        std::vector<std::vector<double>>(probes.begin() + static_cast<std::ptrdiff_t>(begin),
                                         probes.begin() + static_cast<std::ptrdiff_t>(end)));
    std::copy(costs.begin(), costs.end(), probe_cost.begin() + static_cast<std::ptrdiff_t>(begin));
  });
  return probe_cost;
}

// The temperature scale: the sample standard deviation of the finite probe costs (1 when
// fewer than two are finite or it is not positive).
double CostScale(const std::vector<double>& probe_cost) {
  std::vector<double> finite;
  for (double c : probe_cost) {
    if (std::isfinite(c)) finite.push_back(c);
  }
  double scale = 1.0;
  if (finite.size() >= 2) {
    double mean = 0.0;
    for (double c : finite) mean += c;
    mean /= static_cast<double>(finite.size());
    double variance = 0.0;
    for (double c : finite) variance += (c - mean) * (c - mean);
    scale = std::sqrt(variance / static_cast<double>(finite.size() - 1));
  }
  if (!(scale > 0.0) || !std::isfinite(scale)) scale = 1.0;
  return scale;
}

// The walkers' starts: the first at the start values, the others at the best probes.
std::vector<Walker> StartWalkers(const FitProblem& problem, const FsdSettings& s,
                                 const std::vector<std::vector<double>>& probes,
                                 const std::vector<double>& probe_cost) {
  std::vector<std::size_t> order(probes.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t l, std::size_t r) { return probe_cost[l] < probe_cost[r]; });
  std::vector<Walker> walkers(static_cast<std::size_t>(s.walkers));
  walkers[0].x = problem.ToScaled(problem.InitialValues());
  for (std::size_t w = 1; w < walkers.size(); ++w)
    walkers[w].x = probes[order[(w - 1) % order.size()]];
  return walkers;
}

struct PolishCandidate {
  std::string source;
  std::vector<double> start;
  double start_cost = 0.0;
  LocalResult local;
};

// What the polish starts from: every walker's best point and the best probe, near-duplicates
// (within 1e-3 of the unit cube) dropped, the first kept.
std::vector<PolishCandidate> PolishCandidates(const std::vector<Walker>& walkers,
                                              const std::vector<std::vector<double>>& probes,
                                              const std::vector<double>& probe_cost, double scale,
                                              std::size_t n) {
  std::vector<PolishCandidate> candidates;
  for (std::size_t w = 0; w < walkers.size(); ++w) {
    if (std::isfinite(walkers[w].best)) {
      candidates.push_back(
          {"walker " + std::to_string(w), walkers[w].best_x, walkers[w].best * scale, {}});
    }
  }
  std::size_t best_probe = probes.size();
  for (std::size_t k = 0; k < probes.size(); ++k) {
    if (std::isfinite(probe_cost[k]) &&
        (best_probe == probes.size() || probe_cost[k] < probe_cost[best_probe])) {
      best_probe = k;
    }
  }
  if (best_probe < probes.size()) {
    candidates.push_back(
        {"probe " + std::to_string(best_probe), probes[best_probe], probe_cost[best_probe], {}});
  }
  std::vector<PolishCandidate> unique;
  for (const auto& c : candidates) {
    bool duplicate = false;
    for (const auto& u : unique) {
      double d2 = 0.0;
      for (std::size_t k = 0; k < n; ++k)
        d2 += (c.start[k] - u.start[k]) * (c.start[k] - u.start[k]);
      duplicate = duplicate || d2 < 1e-6;
    }
    if (!duplicate) unique.push_back(c);
  }
  return unique;
}

// The lowest of the (polished) candidates; ties to the earlier one, so the outcome is
// thread-independent. `polished` lists every candidate's start and end cost.
struct PolishOutcome {
  std::vector<double> x;  // empty when no candidate had a finite cost
  LocalResult polish;
  std::string winner;
  std::vector<FsdPolished> polished;
};
PolishOutcome BestCandidate(const std::vector<PolishCandidate>& candidates, bool polish_on) {
  PolishOutcome out;
  double best_cost = std::numeric_limits<double>::infinity();
  for (const auto& c : candidates) {
    const bool improved = polish_on && c.local.cost <= c.start_cost;
    const double end_cost = improved ? c.local.cost : c.start_cost;
    out.polished.push_back({c.source, c.start_cost, end_cost});
    if (end_cost < best_cost) {
      best_cost = end_cost;
      out.x = improved ? c.local.scaled : c.start;
      out.polish = c.local;
      out.winner = c.source;
    }
  }
  return out;
}

// The method summary's figures: the settings, the schedule and what each walker reached.
FsdFigures Figures(const FsdSettings& s, const OptimizerOptions& options,
                   const std::vector<Walker>& walkers, const PolishOutcome& outcome, double scale,
                   double a) {
  FsdFigures f;
  f.seed = options.seed;
  f.polished = outcome.polished;
  f.winner = outcome.winner;
  f.walkers = s.walkers;
  f.bursts = s.bursts;
  f.burst_steps = s.burst_steps;
  f.quench_evaluations = s.quench_evaluations;
  f.quench_step = s.quench_step;
  f.probes = s.probes;
  f.cost_scale = scale;
  f.t0 = s.t0;
  f.schedule = "T_k = t0 ln 2 / ln(2 + k), in units of cost_scale";
  f.step_a = a;
  f.initial_spread = s.initial_spread;
  f.fd_step = s.fd_step;
  f.max_step = s.max_step;
  f.polish = s.polish;
  f.polish_evaluations = s.polish_evaluations;
  f.polish_step = s.polish_step;
  for (const auto& w : walkers) {
    f.walker_best_cost.push_back(std::isfinite(w.best) ? w.best * scale
                                                       : std::numeric_limits<double>::quiet_NaN());
  }
  return f;
}

}  // namespace

std::vector<std::string> FsdOptimizer::option_names() const {
  return {"walkers",     "bursts",   "burst_steps",    "quench_evaluations",
          "quench_step", "probes",   "initial_spread", "t0",
          "fd_step",     "max_step", "polish",         "polish_evaluations",
          "polish_step"};
}

FitResult FsdOptimizer::Minimize(const FitProblem& problem, const OptimizerOptions& options) const {
  CheckMethodOptions("fsd", options.method_options, option_names());
  const std::size_t n = problem.num_free();
  const FsdSettings s = ReadSettings(options.method_options, n);
  const auto started = std::chrono::steady_clock::now();
  CountingCost cost(problem, options.progress);
  const int threads = ThreadCount(options.threads);
  // The walkers' evaluation budget (--max-evaluations, shared out after the probes; 0: none).
  const long walker_budget =
      options.max_evaluations > 0
          ? std::max<long>(1, (options.max_evaluations - s.probes) / s.walkers)
          : 0;
  if (options.progress)
    options.progress->ExpectEvaluations(ScheduledEvaluations(s, n, walker_budget));

  // Probe points: the cost's spread sets the temperature scale; the best probes seed walkers.
  Random master(options.seed);
  std::vector<std::vector<double>> probes(static_cast<std::size_t>(s.probes),
                                          std::vector<double>(n));
  for (auto& p : probes) {
    for (double& v : p) v = master.Uniform();
  }
  const std::vector<double> probe_cost = ProbeCosts(cost, probes, threads);
  const double scale = CostScale(probe_cost);
  // Step size a from the wanted initial spread: sqrt(2 a T0) = initial_spread.
  const double a = s.initial_spread * s.initial_spread / (2.0 * s.t0);
  std::vector<Walker> walkers = StartWalkers(problem, s, probes, probe_cost);

  FsdRun run(cost, s, scale);
  // Shared out among the walkers after the probes, each counting its own (repeatable); the
  // polish gets its own budget (polish_evaluations per point) on top.
  run.budget = walker_budget;
  // Each walker has its own generator, seeded by its index: thread-count independent.
  ParallelFor(walkers.size(), threads, [&](std::size_t w) {
    Random random(options.seed * 0x9e3779b97f4a7c15ULL + 7919ULL * (w + 1));
    run.RunWalker(walkers[w], random, a);
  });
  // Polish: every walker's best point and the best probe, each by BOBYQA (in parallel).
  // Polishing several basins rather than only the best-so-far matters on rugged costs (the
  // BLMD current feedback), where the diffusion's best point may sit in a narrow side valley.
  std::vector<PolishCandidate> candidates = PolishCandidates(walkers, probes, probe_cost, scale, n);
  if (s.polish) {
    if (options.progress) {
      options.progress->ExpectEvaluations(static_cast<long>(candidates.size()) *
                                          s.polish_evaluations);
    }
    ParallelFor(candidates.size(), threads, [&](std::size_t k) {
      candidates[k].local = NloptLocal(cost, "bobyqa", candidates[k].start, s.polish_step,
                                       s.polish_evaluations, 1e-9, 1e-12);
    });
  }
  const PolishOutcome outcome = BestCandidate(candidates, s.polish);
  const std::vector<double> x = outcome.x.empty() ? walkers[0].x : outcome.x;

  FitResult result;
  result.values = problem.FromScaled(x);
  result.evaluation = problem.Evaluate(result.values);
  result.estimates = MakeEstimates(problem, result.values);
  OptimizerSummary& summary = result.summary;
  summary.method = "fsd";
  summary.algorithm = "fast simulated diffusion + LN_BOBYQA polish";
  summary.converged = result.evaluation.ok && (!s.polish || outcome.polish.converged);
  summary.termination =
      s.polish ? "schedule completed; polish: " + outcome.polish.message : "schedule completed";
  summary.message = summary.termination;
  summary.raw_code = outcome.polish.code;
  long steps = 0;
  for (const auto& w : walkers) steps += w.steps;
  summary.iterations = steps;
  summary.figures = Figures(s, options, walkers, outcome, scale, a);
  FinishFit(problem, cost, started, &result);
  return result;
}

}  // namespace blmd::internal
