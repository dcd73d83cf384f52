#include "blmd/sim/experiment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "blmd/error.h"
#include "saturating_cast.h"

namespace blmd {
namespace {

// The number of whole half periods of a square wave elapsed at t (t >= t0, half > 0): the
// floor of q = (t - t0)/half, except that a q within 1e-9 (relative) of a whole number counts
// as that number. Sample k of a trace at rate fs sits at t = k/fs, and when a half period is a
// whole number m of samples, q = k/m lands a few rounding errors off every edge: plain
// floor (or fmod) put some edges one sample late. Samples between edges are at
// least 1/m away from a whole q, so the tolerance never moves them while m < 1e8.
double HalfPeriodIndex(double t, double t0, double half) {
  const double q = (t - t0) / half;
  const double nearest = std::round(q);
  if (std::abs(q - nearest) <= 1e-9 * std::max(1.0, std::abs(q))) return nearest;
  return std::floor(q);
}

// The order-n register (Galois form) over GF(2): a state is a polynomial of degree < n in x,
// bit j the coefficient of x^j; one clock multiplies it by x modulo p(x). Bit k of the
// sequence is the coefficient of x^(n-1) of seed·x^k mod p(x), the bit the register shifts
// out at clock k.
std::uint32_t PrbsStep(std::uint32_t state, int order, std::uint32_t polynomial) {
  const std::uint32_t top = (state >> (order - 1)) & 1u;
  const std::uint32_t mask = (order == 32) ? ~0u : ((1u << order) - 1u);
  state = (state << 1) & mask;
  return top != 0 ? state ^ polynomial : state;
}

// a·b mod p(x), both of degree < n.
std::uint32_t PrbsMultiply(std::uint32_t a, std::uint32_t b, int order, std::uint32_t polynomial) {
  std::uint32_t product = 0;
  for (; b != 0; b >>= 1) {
    if ((b & 1u) != 0) product ^= a;
    a = PrbsStep(a, order, polynomial);
  }
  return product;
}

// seed·x^k mod p(x): the state of bit k, by square and multiply (k reduced modulo the
// period 2^n - 1, x's order).
std::uint32_t PrbsJump(std::uint32_t seed, std::uint64_t k, int order, std::uint32_t polynomial) {
  k %= (std::uint64_t{1} << order) - 1u;
  std::uint32_t power = order == 1 ? 1u : 2u;  // x
  std::uint32_t state = seed;
  for (; k != 0; k >>= 1) {
    if ((k & 1u) != 0) state = PrbsMultiply(state, power, order, polynomial);
    power = PrbsMultiply(power, power, order, polynomial);
  }
  return state;
}

int PrbsOutput(std::uint32_t state, int order) {
  return static_cast<int>((state >> (order - 1)) & 1u);
}

// The index of the bit that holds at t >= t0, with the square wave's snapping to the edges.
std::uint64_t PrbsIndex(const InputSignal& signal, double t) {
  return internal::SaturatingCast<std::uint64_t>(HalfPeriodIndex(t, signal.t0, signal.clock));
}

bool PrbsValid(const InputSignal& signal) {
  return signal.clock > 0.0 && PrbsPolynomial(signal.order) != 0 && signal.seed != 0 &&
         signal.seed < (std::uint32_t{1} << signal.order);
}

}  // namespace

std::uint32_t PrbsPolynomial(int order) {
  // Xilinx XAPP052 (P. Alfke, "Efficient Shift Registers, LFSR Counters, and Long
  // Pseudo-Random Sequence Generators", 1996), Table 3: taps n, a, b, c give
  // p(x) = x^n + x^a (+ x^b + x^c) + 1; each checked primitive by tests/unit/inputs_test.cc.
  static constexpr int kTaps[32][4] = {
      {0, 0, 0, 0},    {0, 0, 0, 0},  {1, 0, 0, 0},  {2, 0, 0, 0},  {3, 0, 0, 0},   {3, 0, 0, 0},
      {5, 0, 0, 0},    {6, 0, 0, 0},  {6, 5, 4, 0},  {5, 0, 0, 0},  {7, 0, 0, 0},   {9, 0, 0, 0},
      {6, 4, 1, 0},    {4, 3, 1, 0},  {5, 3, 1, 0},  {14, 0, 0, 0}, {15, 13, 4, 0}, {14, 0, 0, 0},
      {11, 0, 0, 0},   {6, 2, 1, 0},  {17, 0, 0, 0}, {19, 0, 0, 0}, {21, 0, 0, 0},  {18, 0, 0, 0},
      {23, 22, 17, 0}, {22, 0, 0, 0}, {6, 2, 1, 0},  {5, 2, 1, 0},  {25, 0, 0, 0},  {27, 0, 0, 0},
      {6, 4, 1, 0},    {28, 0, 0, 0}};
  if (order < 2 || order > 31) return 0;
  std::uint32_t polynomial = 1u;  // the constant term
  for (const int tap : kTaps[order]) {
    if (tap > 0) polynomial |= 1u << tap;
  }
  return polynomial;
}

double InputSignal::At(double t) const {
  switch (kind) {
    case Kind::kStep:
      return t >= t0 ? offset + amplitude : offset;
    case Kind::kSquare: {
      if (t < t0 || period <= 0.0) return offset;
      // +A in even half periods: sample k is +A exactly when floor(k / (fs·P/2)) is even.
      const double index = HalfPeriodIndex(t, t0, 0.5 * period);
      return std::fmod(index, 2.0) == 0.0 ? offset + amplitude : offset - amplitude;
    }
    case Kind::kSteps:
    case Kind::kRecorded: {
      if (times.empty() || t < times.front()) return kind == Kind::kSteps ? offset : values.front();
      const auto it = std::upper_bound(times.begin(), times.end(), t);
      return values[static_cast<std::size_t>(it - times.begin()) - 1];
    }
    case Kind::kPrbs:
      if (t < t0 || !PrbsValid(*this)) return offset;
      return PrbsBit(t) != 0 ? offset + amplitude : offset - amplitude;
    case Kind::kChirp: {
      if (t < t0) return offset;
      // sin of the phase reduced to one turn first: the phase in turns, less its nearest
      // whole number (exact), loses no more than the turns' own rounding.
      const double turns = ChirpPhase(t) / (2.0 * std::numbers::pi);
      return offset + amplitude * std::sin(2.0 * std::numbers::pi * (turns - std::round(turns)));
    }
  }
  return 0.0;
}

int InputSignal::PrbsBit(double t) const {
  const std::uint32_t polynomial = PrbsPolynomial(order);
  return PrbsOutput(PrbsJump(seed, PrbsIndex(*this, t), order, polynomial), order);
}

double InputSignal::ChirpPhase(double t) const {
  const double tau = t - t0;
  if (!(tau > 0.0) || !(sweep > 0.0)) return 0.0;
  const double s = std::min(tau, sweep);
  double turns = 0.0;  // the integral of f over [0, s]
  if (shape == ChirpShape::kLinear) {
    turns = f0 * s + 0.5 * (f1 - f0) * s * s / sweep;
  } else {
    // f = f0 exp(L s/T), L = ln(f1/f0): the integral is f0 T (exp(L s/T) - 1)/L.
    const double log_ratio = std::log(f1 / f0);
    turns = log_ratio == 0.0 ? f0 * s : f0 * sweep * std::expm1(log_ratio * s / sweep) / log_ratio;
  }
  if (tau > sweep) turns += f1 * (tau - sweep);
  return 2.0 * std::numbers::pi * turns;
}

double InputSignal::ChirpFrequency(double t) const {
  const double tau = t - t0;
  if (!(tau > 0.0)) return f0;
  if (!(tau < sweep)) return f1;
  if (shape == ChirpShape::kLinear) return f0 + (f1 - f0) * tau / sweep;
  return f0 * std::pow(f1 / f0, tau / sweep);
}

bool InputSignal::OpenAt(double t) const {
  if (open.empty() || times.empty() || t < times.front()) return false;
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  return open[static_cast<std::size_t>(it - times.begin()) - 1] != 0.0;
}

void InputCursor::Advance(double t) {
  const auto& times = signal_.times;
  while (index_ + 1 < times.size() && times[index_ + 1] <= t) ++index_;
}

std::uint32_t InputCursor::PrbsStateAt(std::uint64_t k) {
  constexpr std::uint64_t kMaxSteps = 64;  // beyond: a jump (O(order·log k)) is cheaper
  const int order = signal_.order;
  const std::uint32_t polynomial = PrbsPolynomial(order);
  if (!prbs_ready_ || k < prbs_index_ || k - prbs_index_ > kMaxSteps) {
    prbs_state_ = PrbsJump(signal_.seed, k, order, polynomial);
  } else {
    for (std::uint64_t j = prbs_index_; j < k; ++j) {
      prbs_state_ = PrbsStep(prbs_state_, order, polynomial);
    }
  }
  prbs_ready_ = true;
  prbs_index_ = k;
  return prbs_state_;
}

double InputCursor::At(double t) {
  if (signal_.kind == InputSignal::Kind::kPrbs) {
    if (t < signal_.t0 || !PrbsValid(signal_)) return signal_.offset;
    const int bit = PrbsOutput(PrbsStateAt(PrbsIndex(signal_, t)), signal_.order);
    return bit != 0 ? signal_.offset + signal_.amplitude : signal_.offset - signal_.amplitude;
  }
  if (signal_.kind != InputSignal::Kind::kSteps && signal_.kind != InputSignal::Kind::kRecorded) {
    return signal_.At(t);
  }
  const auto& times = signal_.times;
  if (times.empty()) return signal_.offset;
  if (t < times.front()) {
    return signal_.kind == InputSignal::Kind::kSteps ? signal_.offset : signal_.values.front();
  }
  Advance(t);
  return signal_.values[index_];
}

bool InputCursor::OpenAt(double t) {
  if (signal_.open.empty() || signal_.times.empty() || t < signal_.times.front()) return false;
  Advance(t);
  return signal_.open[index_] != 0.0;
}

double InputCursor::NextChange(double t) {
  constexpr double kNever = std::numeric_limits<double>::infinity();
  switch (signal_.kind) {
    case InputSignal::Kind::kStep:
      return t < signal_.t0 ? signal_.t0 : kNever;
    case InputSignal::Kind::kSquare: {
      if (signal_.period <= 0.0) return kNever;
      if (t < signal_.t0) return signal_.t0;
      // The next half-period edge after t. At() counts a time within its snapping tolerance
      // (1e-9 of the half-period count) before an edge as the edge, so the signal is read
      // again from a window wider than that before the edge, and at every call within it
      // (t is returned): a read too early is repeated, a read too late would be wrong.
      const double half = 0.5 * signal_.period;
      const double index = HalfPeriodIndex(t, signal_.t0, half);
      const double next_edge = signal_.t0 + (index + 1.0) * half;
      const double window = 1e-6 * half * std::max(1.0, index + 1.0);
      if (next_edge - t <= window) return t;
      return next_edge - window;
    }
    case InputSignal::Kind::kSteps:
    case InputSignal::Kind::kRecorded: {
      const auto& times = signal_.times;
      if (times.empty()) return kNever;
      if (t < times.front()) return times.front();
      Advance(t);
      return index_ + 1 < times.size() ? times[index_ + 1] : kNever;
    }
    case InputSignal::Kind::kPrbs: {
      if (!PrbsValid(signal_)) return kNever;
      if (t < signal_.t0) return signal_.t0;
      // The next edge at which the bit changes: the register stepped to the end of the
      // current run (at most order bits: runs of an m-sequence are no longer), so O(1)
      // amortised over a run. The window before the edge as for the square wave.
      const std::uint64_t k = PrbsIndex(signal_, t);
      if (!(prbs_run_end_ > prbs_run_begin_ && k >= prbs_run_begin_ && k < prbs_run_end_)) {
        const int order = signal_.order;
        const std::uint32_t polynomial = PrbsPolynomial(order);
        std::uint32_t state = PrbsStateAt(k);
        const int bit = PrbsOutput(state, order);
        std::uint64_t end = k + 1;
        for (state = PrbsStep(state, order, polynomial); PrbsOutput(state, order) == bit;
             state = PrbsStep(state, order, polynomial)) {
          ++end;
        }
        prbs_run_begin_ = k;
        prbs_run_end_ = end;
      }
      const double edge_index = static_cast<double>(prbs_run_end_);
      const double next_edge = signal_.t0 + edge_index * signal_.clock;
      const double window = 1e-6 * signal_.clock * std::max(1.0, edge_index);
      if (next_edge - t <= window) return t;
      return next_edge - window;
    }
    case InputSignal::Kind::kChirp:
      return t;  // continuous: may change at every step (+infinity would freeze it)
  }
  return t;
}

void Experiment::CheckRunnable() const {
  if (!invalid.empty()) throw InputError(invalid);
}

std::vector<double> Experiment::SampleTimes() const {
  const auto n = static_cast<std::size_t>(std::floor(duration * sample_rate + 1e-9)) + 1;
  std::vector<double> times(n);
  for (std::size_t k = 0; k < n; ++k) times[k] = static_cast<double>(k) / sample_rate;
  return times;
}

}  // namespace blmd
