// The blmd model's event-driven integrator (simulation.method = "events";
// docs/model-blmd.md §9). The drive is integrated in segments between the instants at which
// a leg voltage or a compensator's saturation changes; within a segment every leg voltage
// is constant and the drive is smooth, so one Taylor series in the time tau since the
// segment's start, of order 2 for the phase currents, the cosines of the electrical angle and
// the compensators' errors (order 3 for the integrators and the compensator outputs), of
// order 3 for the speed and 4 for the angle, represents the state (kOrder below). The series is
// built by the standard recursion (coefficient k + 1 from the coefficients up to k of the
// right-hand side; Moore 1966, Corliss & Chang 1982): the products w·cos and i·cos are Cauchy
// products. The events are roots of these polynomials:
//   - a comparator crossing: v_c,j(tau) - v_tri(tau) = 0 (carrier linear between vertices);
//   - a blanked phase's current reaching zero (its diode turns off: the phase opens);
//   - a compensator output reaching or leaving +-Vtri, an error changing sign while it is
//     held, the end of a sliding (pinned) stretch;
//   - a friction stop (w reaching zero);
// located by Newton's method safeguarded by bisection from the regula-falsi guess, to the
// last bit (the root returned is the first double past the crossing). Known instants end a
// segment as well: the end of a blanking time (t_edge + delta), a carrier vertex, an input
// edge, max_step after the segment's start. Samples are evaluated from the series at their
// instants (dense output) without ending a segment. The run is deterministic: the same
// request gives the same bits.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/effects.h"
#include "sim/blmd/blmd_events.h"
#include "sim/blmd/blmd_legs.h"
#include "sim/input_read.h"
#include "sim/plain_shaft.h"
#include "sim/sampler.h"

namespace blmd::internal {
namespace {

constexpr double kHalfSqrt3 = 0.86602540378443864676;  // sin(2 pi/3)
constexpr double kNever = std::numeric_limits<double>::infinity();
// The series' order: the phase currents, the speed, the angle's cosines and the
// compensators' errors are polynomials of degree kOrder in tau within a segment; their
// integrals (the angle, the integrators) and hence the compensator outputs of degree
// kDegree = kOrder + 1, the degree of every event function below.
constexpr int kOrder = 2;
constexpr int kDegree = kOrder + 1;
// The speed's series is of order 3 whatever kOrder (the angle's of order 4): its truncation
// error accumulates over the run (the torque's cubic term left out has a nonzero mean over
// a carrier period), while the currents' is corrected at every period by the loop.
constexpr int kSpeedOrder = 3;
static_assert(kSpeedOrder <= kDegree, "the friction stop's polynomial fits an event function");
constexpr double kInverse[] = {0.0, 1.0, 0.5, 1.0 / 3.0, 0.25};  // 1/k

// p(x) = c[0] + c[1] x + ... + c[n] x^n (Horner).
template <int N>
inline double Eval(const double* c, double x) {
  double value = c[N];
#pragma GCC unroll 5
  for (int k = N - 1; k >= 0; --k) value = value * x + c[k];
  return value;
}
template <int N>
inline double EvalDerivative(const double* c, double x) {
  double value = N * c[N];
#pragma GCC unroll 5
  for (int k = N - 1; k >= 1; --k) value = value * x + k * c[k];
  return value;
}

// Refines a root of the polynomial g (degree kDegree) inside [a, b] with g(a) >= 0 > g(b), 0 <= a:
// Newton steps from the regula-falsi point, kept inside the bracket (bisection otherwise), until
// the next Newton iterate's error is below a quarter of the root's rounding. Newton's error
// after a step d from x is at most M d^2 / (2 |g'(x)|), M a bound on |g''| over [0, b]
// (2 |g2| + 6 |g3| b), so the test needs no further evaluation (two steps for the nearly
// linear functions here). The instant returned is the first double past the root (g < 0 there).
double RefineRoot(const double* g, double a, double ga, double b, double gb) {
  double x = a + (b - a) * (ga / (ga - gb));
  double curvature = 0.0;  // M = max |g''| over [0, b]
#pragma GCC unroll 5
  for (int k = kDegree; k >= 2; --k) curvature = curvature * b + k * (k - 1) * std::abs(g[k]);
  // Converged when M d^2 / (2 |g'|) <= 2^-55 |x|, a quarter of x's rounding unit (2^-53).
  constexpr double tolerance = 0x1p-54;
  for (int iteration = 0; iteration < 60; ++iteration) {
    // g(x) and g'(x) in one Horner pass.
    double gx = g[kDegree], slope = 0.0;
#pragma GCC unroll 5
    for (int k = kDegree - 1; k >= 0; --k) {
      slope = slope * x + gx;
      gx = gx * x + g[k];
    }
    if (gx < 0.0) {
      b = x;
    } else {
      a = x;
    }
    const double step = gx / slope;
    double next = x - step;
    const bool newton = next >= a && next <= b;
    if (!newton) next = 0.5 * (a + b);  // also a zero or NaN slope
    // Converged when the Newton iterate is within a quarter ulp of the root (bound above), or
    // the bisection's bracket below the rounding.
    if (newton ? curvature * step * step <= tolerance * std::abs(slope) * std::abs(x) + 1e-300
               : std::abs(next - x) <= 4e-16 * std::abs(x) + 1e-24) {
      // Converged: the root lies within a quarter ulp of `next` (a Newton iterate; a few ulps
      // for bisection), so the double after it is past the root but for g's own rounding:
      // return the first of the next few doubles from there at which g < 0, so that the next
      // segment starts past the event (else the bracket's end, where g < 0). The instants are
      // positive: the next double up is the next bit pattern.
      double past =
          next > 0.0 ? std::bit_cast<double>(std::bit_cast<std::uint64_t>(next) + 1) : next;
      if (!(past <= b)) past = b;
      double g_past = Eval<kDegree>(g, past);
      for (int step = 0; g_past >= 0.0 && step < 8 && past < b && past > 0.0; ++step) {
        past = std::bit_cast<double>(std::bit_cast<std::uint64_t>(past) + 1);
        g_past = Eval<kDegree>(g, past);
      }
      return g_past < 0.0 && past <= b ? past : b;
    }
    x = next;
  }
  return b;
}

// g has no sign change between lo and hi and is not clearly positive: look for an interior
// minimum below zero. While g'' keeps its sign (its quadratic term dominates, the usual
// case) the minimum is where g' = 0, found by Newton's method; otherwise sixteen
// sub-intervals are scanned.
[[gnu::noinline]] double FindDip(const double* g, double lo, double g_lo, double hi) {
  // |g''(x) - 2 g[2]| over [0, hi].
  double variation = 0.0;
#pragma GCC unroll 5
  for (int k = kDegree; k >= 3; --k) variation = variation * hi + k * (k - 1) * std::abs(g[k]);
  variation *= hi;
  if (variation < 2.0 * std::abs(g[2])) {
    if (g[2] <= 0.0) return kNever;  // concave: the minimum is at an end
    double minus_slope[kDegree + 1];
#pragma GCC unroll 5
    for (int k = 0; k < kDegree; ++k) minus_slope[k] = -(k + 1) * g[k + 1];
    minus_slope[kDegree] = 0.0;
    const double s_lo = Eval<kDegree>(minus_slope, lo), s_hi = Eval<kDegree>(minus_slope, hi);
    if (!(s_lo > 0.0 && s_hi < 0.0)) return kNever;  // monotone
    const double critical = RefineRoot(minus_slope, lo, s_lo, hi, s_hi);
    const double g_critical = Eval<kDegree>(g, critical);
    return g_critical < 0.0 ? RefineRoot(g, lo, g_lo, critical, g_critical) : kNever;
  }
  const double span = hi - lo;
  double a = lo, ga = g_lo;
  for (int piece = 1; piece <= 16; ++piece) {
    const double b = piece == 16 ? hi : lo + span * (piece / 16.0);
    const double gb = Eval<kDegree>(g, b);
    if (gb < 0.0) return RefineRoot(g, a, ga, b, gb);
    a = b;
    ga = gb;
  }
  return kNever;
}

// The first tau in (lo, hi] at which the polynomial g is negative, given g(lo) >= 0 (a value
// below zero at lo is rounding just past an event already handled, and taken as zero);
// kNever when g stays >= 0. A sign change between the ends is refined at once; otherwise a
// bound on the curvature shows that g cannot dip below zero in between (the usual case), or
// FindDip looks.
inline double FirstNegative(const double* g, double lo, double hi) {
  if (!(hi > lo)) return kNever;
  if (lo == 0.0) {  // |g - g(0)| <= this bound over [0, hi]: no root when g(0) exceeds it
    double drift = std::abs(g[kDegree]) * hi;
#pragma GCC unroll 5
    for (int k = kDegree - 1; k >= 1; --k) drift = (drift + std::abs(g[k])) * hi;
    if (g[0] > drift) return kNever;
  }
  const double g_lo = std::max(0.0, lo == 0.0 ? g[0] : Eval<kDegree>(g, lo));
  const double g_hi = Eval<kDegree>(g, hi);
  if (g_hi < 0.0) return RefineRoot(g, lo, g_lo, hi, g_hi);
  const double span = hi - lo;
  // |g''| <= curvature over [0, hi].
  double curvature = kDegree * (kDegree - 1) * std::abs(g[kDegree]);
#pragma GCC unroll 5
  for (int k = kDegree - 1; k >= 2; --k) curvature = curvature * hi + k * (k - 1) * std::abs(g[k]);
  if (std::min(g_lo, g_hi) > 0.125 * curvature * span * span) return kNever;
  return FindDip(g, lo, g_lo, hi);
}

// The run's constants.
struct Constants : BlmdParameters {
  double half_period;   // s, Tpwm / 2
  double carrier_rate;  // V/s, |dv_tri/dt|
  double max_step;      // s
  bool lag;             // Tp > 0: y = Kp (Tz/Tp) e + z, Tp z' = Kp (1 - Tz/Tp) e - z
  double lead_direct;   // Tz/Tp (lag) or 1 (PI)
  double lag_input;     // Kp (1 - Tz/Tp)
  ShaftEffects shaft;
  DriveEffects drive;
  bool plain_shaft;

  static Constants From(const ParameterSet& values, const std::vector<std::string>& effects,
                        const SimulationSettings& settings) {
    Constants c;
    static_cast<BlmdParameters&>(c) = BlmdParameters::From(values);
    c.half_period = 0.5 * c.Tpwm;
    c.carrier_rate = 2.0 * c.Vtri / c.half_period;
    // At most one carrier vertex inside a segment; a lag (Tp > 0) is the one fast time
    // constant inside a segment, and the series resolves it only over a fraction of Tp.
    c.max_step =
        std::min(settings.max_step > 0.0 ? settings.max_step : c.half_period, c.half_period);
    if (c.Tp > 0.0) c.max_step = std::min(c.max_step, c.Tp / 16.0);
    c.lag = c.Tp > 0.0;
    c.lead_direct = c.lag ? c.Tz / c.Tp : 1.0;
    c.lag_input = c.lag ? c.Kp * (1.0 - c.Tz / c.Tp) : 0.0;
    c.shaft = ShaftEffects::From(values, effects, settings.friction_smoothing_w);
    c.drive = DriveEffects::From(values, effects);
    c.plain_shaft = PlainShaft(c.shaft);
    return c;
  }
};

// A compensator's integrator over a segment (docs/model-blmd.md §9): integrating (the
// output inside the limits, or outside them with the error pulling it back), held (output
// at a limit, the error pushing further: the conditional integrator stops), or sliding
// (pinned at a limit: integrating would push the output out, holding would let it fall
// back in, so the integrator moves exactly as much as keeps the output at the limit: the
// continuous-time limit of the fixed-step integrator's alternation).
enum class Integrator { kIntegrating, kHeld, kSliding };

// The next edge after t at which the input leaves `value` (the value in force at t): a
// square wave's or PRBS's computed exactly (their NextChange returns a time within a
// snapping window before the edge), otherwise the input's own next change that changes it.
double NextInputEdge(const InputSignal& signal, InputCursor* cursor, double t, double value) {
  switch (signal.kind) {
    case InputSignal::Kind::kSquare: {
      if (signal.period <= 0.0) return kNever;
      if (t < signal.t0) return signal.t0;
      const double half = 0.5 * signal.period;
      double index = std::floor((t - signal.t0) / half) + 1.0;
      double edge = signal.t0 + index * half;
      while (edge <= t) edge = signal.t0 + (++index) * half;
      return edge;
    }
    case InputSignal::Kind::kPrbs: {
      if (t < signal.t0) return signal.t0;
      const double change = cursor->NextChange(t);
      if (!std::isfinite(change)) return kNever;
      double index = std::ceil((std::max(change, t) - signal.t0) / signal.clock - 1e-3);
      double edge = signal.t0 + index * signal.clock;
      while (edge <= t) edge = signal.t0 + (++index) * signal.clock;
      return edge;
    }
    case InputSignal::Kind::kChirp:
      return kNever;  // continuous: read at each segment's start (max_step bounds the error)
    default: {
      // A recorded input (what an identification replays) may change at every sample: its
      // samples that repeat the value in force are no edge, so a segment does not end there.
      double edge = cursor->NextChange(t);
      while (std::isfinite(edge) && cursor->At(edge) == value) edge = cursor->NextChange(edge);
      return edge;
    }
  }
}

}  // namespace

std::string EventsUnsupported(double Tz, double Tp) {
  if (Tz > 0.0 && !(Tp > 0.0)) {
    return "simulation.method 'events' needs Tp > 0 when Tz > 0 (a pure derivative has no "
           "continuous-time state); use 'fixed_euler'";
  }
  return {};
}

// Compiled for AVX2 (three-operand VEX encoding, no fused multiply-adds: the same bits) and
// for the x86-64 baseline, the CPU picking the clone at load time (as the fast path).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
[[gnu::target_clones("avx2", "default")]]
#endif
SimStatus
SimulateBlmdEvents(const BlmdDriveModel& model, const SimulationRequest& request, Trace* out) {
  if (SimStatus status = model.CheckRequest(request); !status.ok()) return status;
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const SimulationSettings& settings = request.settings;
  if (std::string why = EventsUnsupported(values.Get("Tz"), values.Get("Tp")); !why.empty()) {
    return {SimStatus::Code::kInvalidParameters, why, times.front()};
  }
  const Constants c = Constants::From(values, *request.effects, settings);
  const double Ud = c.Ud, Rs = c.Rs, Ke = c.Ke, Kc = c.Kc, Kf = c.Kf, Kp = c.Kp, Ki = c.Ki,
               Vtri = c.Vtri, delta = c.delta, B = c.B;
  const double inv_Ls = 1.0 / c.Ls, inv_J = 1.0 / c.J, p = c.p;
  const double limit = settings.divergence_limit;
  const bool diagnostics = settings.diagnostics;
  const ShaftEffects& shaft = c.shaft;
  const bool sticking_friction = shaft.has_friction() && shaft.smoothing_w <= 0.0;
  const double level_tolerance = 1e-9 * Vtri;  // V: at a limit or on the carrier

  // Output columns, written in place at the sample instants.
  const std::vector<std::string> names = BlmdOutputNames(diagnostics);
  std::vector<std::vector<double>> columns(names.size(), std::vector<double>(times.size()));
  std::size_t next_sample = 0;
  const std::size_t num_samples = times.size();

  InputCursor input(experiment.input);
  EffectAngle effect_angle(request.sample_times, settings.effect_angle);
  const bool chirp = experiment.input.kind == InputSignal::Kind::kChirp;
  // A chirp's demand is linear over a segment (its value and slope at the start): segments
  // of at most 1/200 of its fastest period bound the curvature left out.
  const double chirp_step =
      chirp ? 1.0 / (200.0 * std::max({experiment.input.f0, experiment.input.f1, 1e-9})) : kNever;
  double demand_slope = 0.0;  // V/s, chirp only

  // State.
  const double t_start = times.front();
  double t = t_start;
  double current[3] = {0.0, 0.0, 0.0};
  double integral[3] = {0.0, 0.0, 0.0}, lag_state[3] = {0.0, 0.0, 0.0};
  double w = experiment.initial.w, theta = experiment.initial.theta;
  double cos_a = std::cos(p * theta), sin_a = std::sin(p * theta);
  bool upper[3] = {false, false, false};
  double settled_at[3] = {-kNever, -kNever, -kNever};  // s: the commanded switch conducts
  bool stuck = false, breaking_away = false;
  double demand = 0.0, input_edge = chirp ? kNever : -kNever;  // a chirp has no edge
  long piece = 0;  // carrier piece: [t_start + piece T/2, t_start + (piece + 1) T/2]
  double piece_start = t_start, piece_end = t_start + c.half_period;
  constexpr int kResync = 256;
  int until_resync = kResync;
  bool first = true;
  long stalled = 0;

  // The segment's series (coefficient k multiplies tau^k).
  constexpr int N = kOrder, D = kDegree;
  double ic[3][N + 1] = {}, yc[3][N + 1] = {}, ec[3][N + 1] = {}, cc[3][N + 1] = {};
  double zc[3][N + 1] = {}, uc[3][D + 1] = {}, icoef[3][D + 1] = {};
  constexpr int NS = kSpeedOrder;
  double wc[NS + 1] = {}, thc[NS + 2] = {};
  double phase_voltage[3], neutral = 0.0;
  bool conducting[3];

  // Diagnostics at a sample: the segment's phase voltages and neutral, Te from the series.
  auto write_sample = [&](double tau, double w_shift, double theta_shift) {
    const std::size_t k = next_sample;
    const double ia = Eval<N>(ic[0], tau), ib = Eval<N>(ic[1], tau), icc = Eval<N>(ic[2], tau);
    columns[1][k] = ia + c.drive.i0;
    columns[2][k] = ib;
    columns[3][k] = icc;
    columns[4][k] = Eval<NS>(wc, tau) + w_shift * tau;
    columns[5][k] = Eval<NS + 1>(thc, tau) + theta_shift * tau * tau;
    if (diagnostics) {
      columns[6][k] = phase_voltage[0];
      columns[7][k] = phase_voltage[1];
      columns[8][k] = phase_voltage[2];
      columns[9][k] =
          Ke * (ia * Eval<N>(cc[0], tau) + ib * Eval<N>(cc[1], tau) + icc * Eval<N>(cc[2], tau));
      columns[10][k] = neutral;
    }
    ++next_sample;
  };

  while (next_sample < num_samples) {
    // --- The segment starts at t. Input, carrier piece.
    if (chirp) {
      demand = input.At(t);
      const InputSignal& chirp_input = experiment.input;
      demand_slope = t >= chirp_input.t0
                         ? chirp_input.amplitude * std::cos(chirp_input.ChirpPhase(t)) * 2.0 *
                               std::numbers::pi * chirp_input.ChirpFrequency(t)
                         : 0.0;
    } else if (t >= input_edge) {
      demand = input.At(t);
      input_edge = NextInputEdge(experiment.input, &input, t, demand);
    }
    while (t >= piece_end) {
      ++piece;
      piece_start = piece_end;
      piece_end = t_start + static_cast<double>(piece + 1) * c.half_period;
    }
    const bool rising = (piece & 1) == 0;
    const double carrier0 = rising ? -Vtri + c.carrier_rate * (t - piece_start)
                                   : Vtri - c.carrier_rate * (t - piece_start);
    const double carrier_slope = rising ? c.carrier_rate : -c.carrier_rate;

    // --- Angle, currents, errors, compensator outputs at tau = 0.
    cc[0][0] = cos_a;
    cc[1][0] = -0.5 * cos_a + kHalfSqrt3 * sin_a;
    cc[2][0] = -0.5 * cos_a - kHalfSqrt3 * sin_a;
    const double demand_current = Kc * demand;
    double error0[3], u0[3];
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      error0[j] = demand_current * cc[j][0] - Kf * current[j];
      u0[j] = Kp * c.lead_direct * error0[j] + lag_state[j] + integral[j];
    }

    // --- Comparators at t (the first segment settles the legs on their commands; later a
    // jump of the control, e.g. a demand step, is an edge at t), and the top vertex: a
    // control pinned at +Vtri meets the carrier there, so the upper switch turns off and on
    // again and waits the blanking time, as the fixed-step model does in the limit.
    const bool top_vertex = !first && !rising && t == piece_start;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      const double control = std::clamp(u0[j], -Vtri, Vtri);
      const double difference = control - carrier0;
      if (first) {
        upper[j] = difference > 0.0;
        settled_at[j] = -kNever;
      } else if (top_vertex && control >= Vtri) {
        upper[j] = true;
        settled_at[j] = t + delta;
      } else if ((difference > level_tolerance && !upper[j]) ||
                 (difference < -level_tolerance && upper[j]) ||
                 (std::abs(u0[j]) > Vtri + level_tolerance && upper[j] != (u0[j] > 0.0))) {
        // (A control beyond a limit commands that limit's switch for the whole segment, also
        // when the segment starts on the carrier's vertex at that limit.)
        upper[j] = !upper[j];
        settled_at[j] = t + delta;
      }
    }
    first = false;

    // --- Legs: settled ones at their rail; blanked ones on the diode of their current's
    // sign, or open at zero current (decided below). eqs. 12-14.
    double leg_voltage[3];
    bool blanked[3], undecided[3];
    int num_undecided = 0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      blanked[j] = t < settled_at[j];
      undecided[j] = false;
      conducting[j] = true;
      if (!blanked[j]) {
        leg_voltage[j] = upper[j] ? Ud : 0.0;
      } else if (current[j] > 0.0) {
        leg_voltage[j] = 0.0;
      } else if (current[j] < 0.0) {
        leg_voltage[j] = Ud;
      } else {
        undecided[j] = true;
        ++num_undecided;
        leg_voltage[j] = 0.0;
      }
    }
    const double emf_w = Ke * w;
    double emf0[3];
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) emf0[j] = emf_w * cc[j][0];
    if (num_undecided > 0) {
      // Blanked phases at zero current: try each diode state (lower, upper, open) of each,
      // first open, and keep the first that is consistent: a conducting diode's current
      // moves away from zero in its direction, an open terminal floats within [0, Ud].
      int undecided_index[3] = {0, 0, 0}, n = 0;
#pragma GCC unroll 5
      for (int j = 0; j < 3; ++j) {
        if (undecided[j]) undecided_index[n++] = j;
      }
      int combinations = 1;
#pragma GCC unroll 5
      for (int k = 0; k < n; ++k) combinations *= 3;
      for (int code = 0; code < combinations; ++code) {
        int rest = code;
        int state[3] = {0, 0, 0};  // 0 open, 1 lower, 2 upper
#pragma GCC unroll 5
        for (int k = 0; k < n; ++k) {
          state[undecided_index[k]] = rest % 3;
          rest /= 3;
        }
        bool on[3];
        int num_on = 0;
        double sum_v = 0.0, sum_e = 0.0;
#pragma GCC unroll 5
        for (int j = 0; j < 3; ++j) {
          on[j] = !undecided[j] || state[j] != 0;
          if (undecided[j] && state[j] != 0) leg_voltage[j] = state[j] == 2 ? Ud : 0.0;
          if (on[j]) {
            ++num_on;
            sum_v += leg_voltage[j];
            sum_e += emf0[j];
          }
        }
        bool consistent = true;
        if (num_on >= 2) {
          const double star = (sum_v - sum_e) / num_on;
#pragma GCC unroll 5
          for (int j = 0; j < 3 && consistent; ++j) {
            if (!undecided[j]) continue;
            if (state[j] == 0) {
              const double floating = star + emf0[j];
              consistent = floating >= 0.0 && floating <= Ud;
            } else {
              const double slope = leg_voltage[j] - star - emf0[j];  // Ls di/dt at i = 0
              consistent = state[j] == 1 ? slope > 0.0 : slope < 0.0;
            }
          }
        } else {
// At most one phase could conduct: no current flows; every terminal floats.
#pragma GCC unroll 5
          for (int j = 0; j < 3; ++j) on[j] = false;
        }
        if (consistent || code + 1 == combinations) {
#pragma GCC unroll 5
          for (int j = 0; j < 3; ++j) conducting[j] = num_on >= 2 ? on[j] : false;
          break;
        }
      }
    }
    int num_conducting = 0;
    double sum_v = 0.0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (conducting[j]) {
        ++num_conducting;
        sum_v += leg_voltage[j];
      }
    }
    // Star point: with all three phases conducting v_sg = mean(v_jg) (sum of emfs zero);
    // with one open phase k, v_sg = (v_mg + v_ng)/2 + e_k/2 varies with e_k (its share).
    const bool one_open = num_conducting == 2;
    const bool none = num_conducting < 2;
    neutral = none ? 0.0 : sum_v / num_conducting;
    int open_phase = 0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (!conducting[j]) open_phase = j;
      if (none) conducting[j] = false;
    }

    // --- Taylor series, unrolled: order N = kOrder for the currents, speed and cosines,
    // D = N + 1 for the angle. Coefficient k + 1 of each state from coefficients up to k of
    // its derivative.
    const double w0 = w;
    double effect_torque = 0.0, friction_sign = 0.0, non_friction_torque = 0.0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) ic[j][0] = conducting[j] ? current[j] : 0.0;
    const double Te0 = Ke * (ic[0][0] * cc[0][0] + ic[1][0] * cc[1][0] + ic[2][0] * cc[2][0]);
    if (c.plain_shaft) {
      effect_torque = shaft.TL;
      stuck = false;
    } else {
      // Effects held at the segment's start here (corrected to its midpoint below).
      const double theta_effects = effect_angle.At(t, theta);
      const double non_friction = shaft.NonFrictionTorque(theta_effects) + shaft.DragTorque(w0);
      bool now_stuck = false;
      double friction = shaft.StepFriction(w0, Te0 - non_friction, &now_stuck);
      if (now_stuck && breaking_away) {  // the breakaway event just passed (rounding aside)
        now_stuck = false;
        const double breakaway = shaft.FrictionMagnitude(0.0);
        friction = Te0 - non_friction > 0.0 ? breakaway : -breakaway;
      }
      breaking_away = false;
      stuck = now_stuck;
      non_friction_torque = non_friction;
      friction_sign = w0 > 0.0 ? 1.0 : (w0 < 0.0 ? -1.0 : (friction > 0.0 ? 1.0 : -1.0));
      effect_torque = non_friction + friction;
    }
    const double moving = stuck ? 0.0 : 1.0;
    const double B_J = B * inv_J, Ke_J = Ke * inv_J;
    // Phase voltages (constant over the segment) and the star point's emf share.
    const double share_weight = one_open ? 0.5 : 0.0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) phase_voltage[j] = conducting[j] ? leg_voltage[j] - neutral : 0.0;
    auto rotate = [&](int k, double Ck, double Sk) {
      cc[0][k] = Ck;
      const double half_c = -0.5 * Ck, h_s = kHalfSqrt3 * Sk;
      cc[1][k] = half_c + h_s;
      cc[2][k] = half_c - h_s;
    };
    auto next_currents = [&](int k, double share) {  // ic[.][k + 1] from ec[.][k]
      const double scale = inv_Ls / (k + 1);
#pragma GCC unroll 5
      for (int j = 0; j < 3; ++j) {
        const double drive = (k == 0 ? phase_voltage[j] : 0.0) - share - ec[j][k] - Rs * ic[j][k];
        ic[j][k + 1] = conducting[j] ? drive * scale : 0.0;
      }
    };
// Order 0 -> 1.
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) ec[j][0] = emf0[j];
    const double share0 = share_weight * ec[open_phase][0];
    next_currents(0, share0);
    wc[0] = w0;
    wc[1] = moving * ((Te0 - effect_torque) * inv_J - B_J * w0);
    const double om0 = p * w0, om1 = p * wc[1];
    const double C1 = -om0 * sin_a, S1 = om0 * cos_a;
    rotate(1, C1, S1);
    // Order 1 -> 2.
    double Te1 = 0.0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      ec[j][1] = Ke * (w0 * cc[j][1] + wc[1] * cc[j][0]);
      Te1 += ic[j][0] * cc[j][1] + ic[j][1] * cc[j][0];
    }
    next_currents(1, share_weight * ec[open_phase][1]);
    wc[2] = moving * 0.5 * (Ke_J * Te1 - B_J * wc[1]);
    [[maybe_unused]] const double om2 = p * wc[2];
    const double C2 = -0.5 * (om0 * S1 + om1 * sin_a), S2 = 0.5 * (om0 * C1 + om1 * cos_a);
    rotate(2, C2, S2);
    // Order 2 -> 3: the speed's, and with kOrder = 3 the currents' and cosines'.
    double Te2 = 0.0;
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if constexpr (N >= 3) ec[j][2] = Ke * (w0 * cc[j][2] + wc[1] * cc[j][1] + wc[2] * cc[j][0]);
      Te2 += ic[j][0] * cc[j][2] + ic[j][1] * cc[j][1] + ic[j][2] * cc[j][0];
    }
    wc[3] = moving * (1.0 / 3.0) * (Ke_J * Te2 - B_J * wc[2]);
    if constexpr (N >= 3) {
      next_currents(2, share_weight * ec[open_phase][std::min(2, N)]);
      const double C3 = -(1.0 / 3.0) * (om0 * S2 + om1 * S1 + om2 * sin_a);
      const double S3 = (1.0 / 3.0) * (om0 * C2 + om1 * C1 + om2 * cos_a);
      rotate(std::min(3, N), C3, S3);
    }
    static_assert(N == 2 || N == 3, "the recursion is unrolled for orders 2 and 3");
    thc[0] = theta;
#pragma GCC unroll 5
    for (int k = 0; k <= NS; ++k) thc[k + 1] = kInverse[k + 1] * wc[k];
    if (one_open) {  // the open terminal floats at v_sg + e_k: its phase voltage is e_k
      phase_voltage[open_phase] = ec[open_phase][0];
      neutral += share0;
    }

    // --- Compensators: errors, lead-lag, integrators, outputs u_j (series).
    Integrator mode[3];
    double sign_limit[3];
    double errc[3][N + 1];
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      double* e = errc[j];
#pragma GCC unroll 5
      for (int k = 0; k <= N; ++k) e[k] = demand_current * cc[j][k] - Kf * ic[j][k];
      if (chirp) {  // (Td0 + Td1 tau) c_j(tau)
        for (int k = 1; k <= N; ++k) e[k] += Kc * demand_slope * cc[j][k - 1];
      }
      if (c.lag) {
        zc[j][0] = lag_state[j];
#pragma GCC unroll 5
        for (int k = 0; k < N; ++k) {
          zc[j][k + 1] = (c.lag_input * e[k] - zc[j][k]) / (c.Tp * (k + 1));
        }
#pragma GCC unroll 5
        for (int k = 0; k <= N; ++k) yc[j][k] = Kp * c.lead_direct * e[k] + zc[j][k];
      } else {
#pragma GCC unroll 5
        for (int k = 0; k <= N; ++k) yc[j][k] = Kp * e[k];
      }
      const double u = yc[j][0] + integral[j];
      const double s = u >= 0.0 ? 1.0 : -1.0;
      sign_limit[j] = s;
      Integrator m;
      if (std::abs(u) < Vtri - level_tolerance) [[likely]] {
        m = Integrator::kIntegrating;
      } else if (std::abs(u) > Vtri + level_tolerance) {
        m = s * e[0] < 0.0 ? Integrator::kIntegrating : Integrator::kHeld;
      } else if (s * (yc[j][1] + Ki * e[0]) <= 0.0) {
        m = Integrator::kIntegrating;  // at the limit, moving back inside
      } else if (s * yc[j][1] >= 0.0) {
        m = s * e[0] < 0.0 ? Integrator::kIntegrating : Integrator::kHeld;
      } else {
        m = Integrator::kSliding;
      }
      mode[j] = m;
      icoef[j][0] = integral[j];
      if (m == Integrator::kIntegrating) {
        icoef[j][1] = Ki * e[0];
        icoef[j][2] = 0.5 * Ki * e[1];
        icoef[j][3] = (1.0 / 3.0) * Ki * e[2];
        if constexpr (N >= 3) icoef[j][4] = 0.25 * Ki * e[3];
      } else if (m == Integrator::kHeld) {
        icoef[j][1] = icoef[j][2] = icoef[j][3] = 0.0;
        if constexpr (N >= 3) icoef[j][4] = 0.0;
      } else {
        icoef[j][1] = -yc[j][1];
        icoef[j][2] = -yc[j][2];
        if constexpr (N >= 3) icoef[j][3] = -yc[j][std::min(3, N)];
        icoef[j][D] = 0.0;
      }
#pragma GCC unroll 5
      for (int k = 0; k <= N; ++k) uc[j][k] = yc[j][k] + icoef[j][k];
      uc[j][D] = icoef[j][D];
    }

    // --- The segment's end: the known instants first. The end of a blanking time ends the
    // segment only when the leg voltage changes there (the diode's rail is not the one the
    // switch now turning on ties the leg to).
    // A carrier vertex ends the segment only when a control is pinned at +Vtri there (the
    // top vertex's pulse, above); otherwise the comparators see the carrier's two pieces.
    const double vertex = piece_end - t;
    double T = std::min({input_edge - t, c.max_step, chirp_step, times.back() - t});
    if (rising && vertex <= T) {
#pragma GCC unroll 5
      for (int j = 0; j < 3; ++j) {
        if (u0[j] >= Vtri - level_tolerance) T = vertex;
      }
    }
    double blank_end[3];
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      blank_end[j] = blanked[j] ? settled_at[j] - t : 0.0;
      if (blanked[j] && (!conducting[j] || leg_voltage[j] != (upper[j] ? Ud : 0.0))) {
        T = std::min(T, blank_end[j]);
      }
    }
    // Then the roots. Comparators: first crossing of each leg whose control is inside the
    // limits; a crossing that leaves the leg voltage unchanged (the switch that turns off
    // hands its current to the diode of the same rail) does not end the segment, its
    // blanking end does; a second crossing of the same leg within it ends the segment.
    double cross[3] = {kNever, kNever, kNever};   // first crossing (tau)
    bool cross_ends[3] = {false, false, false};   // it ends the segment
    double cross2[3] = {kNever, kNever, kNever};  // a second crossing after a quiet one
    double g[D + 1];
    // The carrier after the vertex, as a polynomial in tau: v_tri(vertex) - slope (tau - vertex).
    const double carrier_after0 = (rising ? Vtri : -Vtri) + carrier_slope * vertex;
    // The first tau in (lo, hi] at which s (u_j - v_tri) < 0: leg j's comparator leaves the
    // command s.
    auto first_crossing = [&](int j, double s, double lo, double hi) {
      double h[D + 1] = {s * (uc[j][0] - carrier0), s * (uc[j][1] - carrier_slope)};
#pragma GCC unroll 5
      for (int k = 2; k <= D; ++k) h[k] = s * uc[j][k];
      if (vertex < hi) {
        if (vertex > lo) {
          const double tau = FirstNegative(h, lo, vertex);
          if (tau != kNever) return tau;
          lo = vertex;
        }
        h[0] = s * (uc[j][0] - carrier_after0);
        h[1] = s * (uc[j][1] + carrier_slope);
      }
      return FirstNegative(h, lo, hi);
    };
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (std::abs(u0[j]) > Vtri + level_tolerance) continue;  // clamped: no crossing
      const double s = upper[j] ? 1.0 : -1.0;
      const double tau = first_crossing(j, s, 0.0, T);
      if (tau == kNever) continue;
      cross[j] = tau;
      // The leg voltage after the edge: the diode of the current's sign during blanking.
      const double i_at = Eval<N>(ic[j], tau);
      const double after = i_at > 0.0 ? 0.0 : Ud;
      cross_ends[j] = !conducting[j] || i_at == 0.0 || after != leg_voltage[j];
      if (cross_ends[j]) {
        T = std::min(T, tau);
      } else {
        T = std::min(T, tau + delta);
        cross2[j] = first_crossing(j, -s, tau, T);
        T = std::min(T, cross2[j]);
      }
    }
    // Blanked phases reaching zero current (their diode turns off), within their blanking.
    double zero[3] = {kNever, kNever, kNever};
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (!conducting[j]) continue;
      double from = kNever, to = 0.0;
      if (blanked[j]) from = 0.0, to = blank_end[j];
      if (cross[j] < T && !cross_ends[j]) from = std::min(from, cross[j]), to = cross[j] + delta;
      to = std::min(to, T);
      if (!(to > from)) continue;
      const double i_from = from == 0.0 ? ic[j][0] : Eval<N>(ic[j], from);
      const double s = i_from > 0.0 ? 1.0 : (i_from < 0.0 ? -1.0 : 0.0);
      if (s == 0.0) continue;
#pragma GCC unroll 5
      for (int k = 0; k <= N; ++k) g[k] = s * ic[j][k];
      g[D] = 0.0;
      zero[j] = FirstNegative(g, from, to);
      T = std::min(T, zero[j]);
    }
// Compensator limits.
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      const double s = sign_limit[j];
      double event = kNever;
      const double* u = uc[j];
      if (mode[j] == Integrator::kIntegrating && std::abs(u0[j]) <= Vtri + level_tolerance) {
        // Reaching either limit; none when |u| cannot reach Vtri within T (a bound).
        double reach = 0.0;
#pragma GCC unroll 5
        for (int k = D; k >= 0; --k) reach = reach * T + std::abs(u[k]);
        if (reach < Vtri) continue;
        for (const double side : {1.0, -1.0}) {
          g[0] = Vtri - side * u[0];
#pragma GCC unroll 5
          for (int k = 1; k <= D; ++k) g[k] = -side * u[k];
          event = std::min(event, FirstNegative(g, 0.0, T));
        }
      } else if (mode[j] == Integrator::kIntegrating || mode[j] == Integrator::kHeld) {
        // Outside or at the limit: back inside, or the error's sign changes (the integrator
        // starts or stops).
        g[0] = s * u[0] - Vtri;
#pragma GCC unroll 5
        for (int k = 1; k <= D; ++k) g[k] = s * u[k];
        event = FirstNegative(g, 0.0, T);
        const double toward = mode[j] == Integrator::kHeld ? s : -s;
#pragma GCC unroll 5
        for (int k = 0; k <= N; ++k) g[k] = toward * errc[j][k];
        g[D] = 0.0;
        event = std::min(event, FirstNegative(g, 0.0, T));
      } else {
// Sliding ends when y' turns outward or y' + Ki e turns inward.
#pragma GCC unroll 5
        for (int k = 0; k < N; ++k) g[k] = -s * (k + 1) * yc[j][k + 1];
        g[N] = g[D] = 0.0;
        event = FirstNegative(g, 0.0, T);
#pragma GCC unroll 5
        for (int k = 0; k < N; ++k) g[k] = s * ((k + 1) * yc[j][k + 1] + Ki * errc[j][k]);
        g[N] = s * Ki * errc[j][N];
        g[D] = 0.0;
        event = std::min(event, FirstNegative(g, 0.0, T));
      }
      // A limit event right at the start is the classification's own boundary: skip it.
      if (event > 1e-12 * c.Tpwm) T = std::min(T, event);
    }
    // Friction: a stuck shaft breaking away (the drive torque, a cubic in tau while the angle
    // holds, leaving the band of the breakaway torque around the other torques).
    if (stuck) {
      const double breakaway = shaft.FrictionMagnitude(0.0);
      const double other = non_friction_torque;
      double torque[N + 1];
#pragma GCC unroll 5
      for (int k = 0; k <= N; ++k) {
        torque[k] = Ke * (cc[0][0] * ic[0][k] + cc[1][0] * ic[1][k] + cc[2][0] * ic[2][k]);
      }
      for (const double side : {1.0, -1.0}) {
        g[0] = breakaway - side * (torque[0] - other);
#pragma GCC unroll 5
        for (int k = 1; k <= N; ++k) g[k] = -side * torque[k];
        g[D] = 0.0;
        const double tau = FirstNegative(g, 0.0, T);
        if (tau <= T) {
          T = tau;
          breaking_away = true;
        }
      }
    }
    // Friction: the shaft stopping.
    bool stops = false;
    if (sticking_friction && !stuck && w0 != 0.0) {
      const double s = w0 > 0.0 ? 1.0 : -1.0;
#pragma GCC unroll 5
      for (int k = 0; k <= D; ++k) g[k] = k <= NS ? s * wc[std::min(k, NS)] : 0.0;
      const double tau = FirstNegative(g, 0.0, T);
      if (tau <= T) {
        T = tau;
        stops = true;
      }
    }
    if (!(T > 1e-12 * c.Tpwm)) {
      T = std::max(T, 0.0);
      if (++stalled > 1000) {
        return {SimStatus::Code::kDiverged,
                "the events integrator made no progress (switching without end)", t};
      }
    } else {
      stalled = 0;
    }

    // --- Effects at the segment's midpoint (second order in the effect torques).
    double w_shift = 0.0, theta_shift = 0.0;
    if (!c.plain_shaft && !stuck) {
      const double mid = 0.5 * T;
      const double w_mid = Eval<NS>(wc, mid), theta_mid = Eval<NS + 1>(thc, mid);
      const double theta_mid_effects =
          settings.effect_angle ? effect_angle.At(t + mid, theta_mid) : theta_mid;
      double torque_mid = shaft.NonFrictionTorque(theta_mid_effects) + shaft.DragTorque(w_mid);
      if (shaft.has_friction()) {
        torque_mid += shaft.smoothing_w > 0.0
                          ? shaft.FrictionMagnitude(w_mid) * std::tanh(w_mid / shaft.smoothing_w)
                          : friction_sign * shaft.FrictionMagnitude(w_mid);
      }
      w_shift = -(torque_mid - effect_torque) * inv_J;  // d(w)/dtau correction
      theta_shift = 0.5 * w_shift;
    }

    // --- Samples inside (t, t + T] (and the run's first one at t).
    const double t_end = t + T;
    while (next_sample < num_samples && times[next_sample] <= t_end) {
      const double tau = std::max(0.0, times[next_sample] - t);
      write_sample(tau, w_shift, theta_shift);
    }

// --- Advance to t + T and apply the events that end the segment there.
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      current[j] = conducting[j] ? Eval<N>(ic[j], T) : 0.0;
      integral[j] = Eval<D>(icoef[j], T);
      if (c.lag) lag_state[j] = Eval<N>(zc[j], T);
      if (zero[j] == T) current[j] = 0.0;
    }
    const double theta_old = theta;
    if (!stuck) {
      w = stops ? 0.0 : Eval<NS>(wc, T) + w_shift * T;
      theta = Eval<NS + 1>(thc, T) + theta_shift * T * T;
    }
// Commands: a quiet crossing before the end, a crossing at the end, a second one.
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (cross[j] <= T) {
        upper[j] = !upper[j];
        settled_at[j] = t + cross[j] + delta;
        if (cross2[j] <= T) {
          upper[j] = !upper[j];
          settled_at[j] = t + cross2[j] + delta;
        }
      }
    }
    // The electrical angle: rotated by x = p (theta_new - theta_old) (Taylor series exact to
    // rounding for |x| < 0.05: the first terms left out, x^10/10! and x^11/11!, are below
    // 3e-20; the segments of the bundled step at full speed turn by up to 0.04), and
    // resynchronised with std::cos/std::sin every kResync = 256 segments (a rotation's
    // rounding, ~1e-16, adds up to ~1e-14 in between).
    const double x = p * (theta - theta_old);
    if (--until_resync == 0 || stops || !(std::abs(x) < 0.05)) {
      cos_a = std::cos(p * theta);
      sin_a = std::sin(p * theta);
      until_resync = kResync;
    } else {
      const double x2 = x * x;
      const double cos_x =
          1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0 - x2 * (1.0 / 40320.0))));
      const double sin_x =
          x * (1.0 -
               x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0 - x2 * (1.0 / 362880.0)))));
      const double rotated = cos_a * cos_x - sin_a * sin_x;
      sin_a = sin_a * cos_x + cos_a * sin_x;
      cos_a = rotated;
    }
    // Known instants land exactly (no rounding of t + (t_k - t)).
    double t_next = t_end;
    if (T == piece_end - t) t_next = piece_end;
    if (T == input_edge - t) t_next = input_edge;
    if (T == times.back() - t) t_next = times.back();
#pragma GCC unroll 5
    for (int j = 0; j < 3; ++j) {
      if (blanked[j] && T == blank_end[j]) t_next = settled_at[j];
    }
    t = t_next;
    if (!(std::abs(current[0] + c.drive.i0) <= limit && std::abs(current[1]) <= limit &&
          std::abs(current[2]) <= limit && std::abs(w) <= limit && std::abs(theta) <= limit)) {
      return {SimStatus::Code::kDiverged, DivergedMessage(limit), t};
    }
  }

  *out = Trace();
  out->Set("t", times);
  std::vector<double>& u_column = columns[0];
  InputCursor u_cursor(experiment.input);
  // The input is read again only where it may have changed (InputCursor::NextChange).
  double u_value = 0.0, u_next = -kNever;
  for (std::size_t k = 0; k < times.size(); ++k) {
    const double at = InputReadTime(times[k], settings.dt);
    if (at >= u_next) {
      u_value = u_cursor.At(at);
      u_next = u_cursor.NextChange(at);
    }
    u_column[k] = u_value;
  }
  for (std::size_t k = 0; k < names.size(); ++k) out->Set(names[k], std::move(columns[k]));
  return SimStatus::Ok();
}

}  // namespace blmd::internal
