#include "blmd/ident/fit/units_check.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "blmd/constants.h"
#include "blmd/io/csv.h"

namespace blmd {
namespace {

// One model unit (rad/s, rad, A) expressed in a unit a recorder may have used.
struct OtherUnit {
  const char* column;
  const char* unit;
  const char* model_unit;
  double factor;
};
constexpr OtherUnit kOtherUnits[] = {
    {"w", "rpm", "rad/s", 60.0 / (2.0 * kPi)},  {"w", "deg/s", "rad/s", 180.0 / kPi},
    {"w", "rev/s", "rad/s", 1.0 / (2.0 * kPi)}, {"theta", "deg", "rad", 180.0 / kPi},
    {"theta", "rev", "rad", 1.0 / (2.0 * kPi)}, {"i", "mA", "A", 1000.0},
};
constexpr double kRatioTolerance = 0.2;  // |observed / factor - 1| at most this
constexpr double kShapeAgreement = 0.9;  // uncentred R^2 of m ~ g s at least this

const OtherUnit* Matching(const std::string& column, double ratio) {
  if (!(std::isfinite(ratio) && ratio > 0.0)) return nullptr;
  for (const OtherUnit& unit : kOtherUnits) {
    if (column == unit.column && std::abs(ratio / unit.factor - 1.0) <= kRatioTolerance)
      return &unit;
  }
  return nullptr;
}

// The least-squares gain of each observed column's measurement over its simulation at
// `values`, pooled over every trace, and how much of the measured power g s explains; empty
// when a simulation fails. Every trace is simulated once for all the columns.
struct Gain {
  double gain = 0.0;
  double r2 = 0.0;
  bool ok = false;
};
std::vector<Gain> ColumnGains(const FitProblem& problem, const std::vector<double>& values) {
  const std::vector<std::string>& observe = problem.observe();
  std::vector<double> ms(observe.size(), 0.0), ss(observe.size(), 0.0), mm(observe.size(), 0.0);
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    Trace simulated;
    if (!problem.Simulate(k, values, &simulated).ok()) return {};
    for (std::size_t c = 0; c < observe.size(); ++c) {
      if (!simulated.Has(observe[c])) continue;
      const std::vector<double>& s = simulated.Column(observe[c]);
      const std::vector<double>& m = problem.measured(k).Column(observe[c]);
      for (std::size_t n = 0; n < m.size() && n < s.size(); ++n) {
        ms[c] += m[n] * s[n];
        ss[c] += s[n] * s[n];
        mm[c] += m[n] * m[n];
      }
    }
  }
  std::vector<Gain> gains(observe.size());
  for (std::size_t c = 0; c < observe.size(); ++c) {
    if (!(ss[c] > 0.0 && mm[c] > 0.0 && std::isfinite(ms[c] + ss[c] + mm[c]))) continue;
    gains[c].gain = ms[c] / ss[c];
    gains[c].r2 = 1.0 - (mm[c] - gains[c].gain * ms[c]) / mm[c];  // sum (m - g s)^2 = mm - g ms
    gains[c].ok = true;
  }
  return gains;
}

}  // namespace

std::string UnitsHint::ScaleFlag() const {
  return "--scale " + column + "=" + FormatSignificant(1.0 / factor, 17);
}

std::vector<UnitsHint> CheckUnits(const FitProblem& problem, const std::vector<double>& fitted) {
  std::vector<UnitsHint> hints;
  if (problem.equation_error()) return hints;
  auto hinted = [&](const std::string& column) {
    for (const UnitsHint& hint : hints)
      if (hint.column == column) return true;
    return false;
  };
  const std::vector<double> start = problem.InitialValues();
  // The config's values say what the user knows of the rig, unless they are the starting
  // config's typical values (blmd-sim --init-config) unchanged: a shaft of 5e-4 kg·m² fitted
  // from the typical 0.02 is 40 times faster than the start for no fault of the units (the
  // delta-a3 starting config flagged 22 of 60 exact rigid records as "deg/s?").
  bool typical_start = false;
  for (std::size_t k = 0; k < problem.num_free() && k < start.size(); ++k) {
    const ParamInfo* info = problem.config().model->FindParameter(problem.free()[k].name);
    if (!info || info->typical == 0.0) continue;
    typical_start = start[k] == info->typical;
    if (!typical_start) break;
  }
  for (const auto& [values, where] :
       {std::pair{&start, "the config's values"}, std::pair{&fitted, "the fitted values"}}) {
    if (values->size() != problem.num_free()) continue;
    if (values == &start && typical_start) continue;
    const std::vector<Gain> gains = ColumnGains(problem, *values);
    for (std::size_t c = 0; c < gains.size(); ++c) {
      const std::string& column = problem.observe()[c];
      const Gain& g = gains[c];
      if (hinted(column) || !g.ok || g.r2 < kShapeAgreement) continue;
      if (const OtherUnit* unit = Matching(column, g.gain)) {
        hints.push_back(
            {column, unit->unit, unit->model_unit, unit->factor, g.gain,
             "the measured '" + column + "' is " + FormatSignificant(g.gain, 4) +
                 " times the one simulated at " + where + " (the shapes agree: R² " +
                 (g.r2 >= 0.99995 ? std::string("> 0.9999") : FormatSignificant(g.r2, 4)) + ")"});
      }
    }
  }
  // In the order of the observed columns, whichever parameter set showed it.
  const std::vector<std::string>& columns = problem.observe();
  auto index = [&](const UnitsHint& hint) {
    return std::find(columns.begin(), columns.end(), hint.column) - columns.begin();
  };
  std::stable_sort(hints.begin(), hints.end(),
                   [&](const UnitsHint& a, const UnitsHint& b) { return index(a) < index(b); });
  // A back-EMF constant (V·s/rad) fitted at config / factor: the speed it multiplies was in
  // another unit.
  if (fitted.size() != problem.num_free() || hinted("w") ||
      std::find(columns.begin(), columns.end(), "w") == columns.end())
    return hints;
  const ParameterSet config_values = problem.Parameters(start);
  for (std::size_t k = 0; k < problem.num_free(); ++k) {
    const FreeParameter& p = problem.free()[k];
    const ParamInfo* info = problem.config().model->FindParameter(p.name);
    if (!info || info->unit != "V·s/rad" || !(fitted[k] > 0.0)) continue;
    const double ratio = config_values.Get(p.name) / fitted[k];
    if (const OtherUnit* unit = Matching("w", ratio)) {
      hints.push_back({"w", unit->unit, unit->model_unit, unit->factor, ratio,
                       "the fitted " + p.name + " = " + FormatSignificant(fitted[k], 4) +
                           " is the start value " +
                           FormatSignificant(config_values.Get(p.name), 4) + " divided by " +
                           FormatSignificant(ratio, 4)});
      break;
    }
  }
  return hints;
}

}  // namespace blmd
