#include "blmd/sim/experiment.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "blmd/error.h"

namespace blmd {
namespace {

// The number of whole half periods of a square wave elapsed at t (t >= t0, half > 0): the
// floor of q = (t - t0)/half, except that a q within 1e-9 (relative) of a whole number counts
// as that number. Sample k of a trace at rate fs sits at t = k/fs, and when a half period is a
// whole number m of samples, q = k/m lands a few rounding errors off every edge: plain
// floor (or fmod) put some edges one sample late (issue 18). Samples between edges are at
// least 1/m away from a whole q, so the tolerance never moves them while m < 1e8.
double HalfPeriodIndex(double t, double t0, double half) {
  const double q = (t - t0) / half;
  const double nearest = std::round(q);
  if (std::abs(q - nearest) <= 1e-9 * std::max(1.0, std::abs(q))) return nearest;
  return std::floor(q);
}

}  // namespace

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
  }
  return 0.0;
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

double InputCursor::At(double t) {
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
