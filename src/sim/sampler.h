// Private helper shared by the fixed-step models: writes the outputs at the requested
// sample instants. A sample that falls inside a step is linearly interpolated between the
// step's end points (exact when the sample lies on the step grid, the usual case).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

#include "blmd/sim/experiment.h"
#include "blmd/sim/trace.h"

namespace blmd::internal {

class OutputSampler {
 public:
  // Each column zero-filled in place (not copied from a zero-filled prototype).
  OutputSampler(const std::vector<double>& times, const std::vector<std::string>& names)
      : times_(times), columns_(names.size()), names_(names) {
    for (auto& column : columns_) column.resize(times.size());
  }

  bool done() const { return next_ >= times_.size(); }
  std::size_t next() const { return next_; }
  double next_time() const { return times_[next_]; }

  // Records samples with t in (t_prev, t_now] (and t == t_prev for the very first one).
  void Record(double t_prev, const double* prev, double t_now, const double* now) {
    const double span = t_now - t_prev;
    const double tolerance = 1e-9 * span;
    while (next_ < times_.size() && times_[next_] <= t_now + tolerance) {
      const double t = times_[next_];
      double alpha = span > 0.0 ? (t - t_prev) / span : 1.0;
      if (alpha > 1.0 - 1e-9) alpha = 1.0;
      if (alpha < 0.0) alpha = 0.0;
      for (std::size_t c = 0; c < columns_.size(); ++c) {
        columns_[c][next_] = alpha == 1.0 ? now[c] : prev[c] + alpha * (now[c] - prev[c]);
      }
      ++next_;
    }
  }

  // Moves the columns into *out after "t".
  void Finish(Trace* out) {
    *out = Trace();
    out->Set("t", times_);
    for (std::size_t c = 0; c < columns_.size(); ++c) out->Set(names_[c], std::move(columns_[c]));
  }

 private:
  const std::vector<double>& times_;
  std::vector<std::vector<double>> columns_;
  std::vector<std::string> names_;
  std::size_t next_ = 0;
};

inline bool AllFinite(const double* values, std::size_t n, double limit) {
  for (std::size_t k = 0; k < n; ++k) {
    if (!std::isfinite(values[k]) || std::abs(values[k]) > limit) return false;
  }
  return true;
}

// The reason of a kDiverged status, the same for every model and every step (failures are
// counted by reason): "simulation diverged (non-finite or |state| > 1e+09)".
inline std::string DivergedMessage(double limit) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", limit);
  return std::string("simulation diverged (non-finite or |state| > ") + buffer + ")";
}

// True when the request forces the position-dependent effects onto a given angle
// (SimulationSettings::effect_angle): the fast paths leave such runs to their reference
// paths, which implement it.
inline bool ForcedEffectAngle(const SimulationSettings& settings) {
  return settings.effect_angle != nullptr;
}

}  // namespace blmd::internal
