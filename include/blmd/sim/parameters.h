// Named parameter values and their descriptions.
// A model is a const description; the values it runs with live in a ParameterSet.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace blmd {

// Description of one parameter of a model or an effect.
struct ParamInfo {
  std::string name;            // symbol as in docs/ (R, L, Kt, J, B, Tc, ...)
  std::string unit;            // SI unit, e.g. "kg·m²"
  std::string meaning;         // one line
  bool positive = true;        // must be > 0 (searched on a log scale when free)
  bool non_negative = false;   // may be 0 but not < 0 (e.g. friction Tc)
  double default_lower = 0.0;  // default identification bounds
  double default_upper = 0.0;
  bool optional = false;  // may be left out of a config; then default_value
  double default_value = 0.0;
  // A plausible value, in `unit`, for a model's starting config (blmd-sim --init-config,
  // io/starting_config.h); 0 for effects' parameters, which carry none.
  double typical = 0.0;
  // An effect's parameter: its name inside the effect's config object and in blmd-sim
  // --effect when that differs from `name`, the flat name used everywhere else (free,
  // initial, bounds, reports). Gravity's `phase` is `gravity_phase` in the flat namespace,
  // where cogging owns `phase` (docs/effects.md). Empty: the same as `name`.
  std::string key;
  // An angle that wraps (a phase, rad, periodic in 2π): its value near a bound is no sign of a
  // poor fit, and two values that differ by 2π are the same model. Discovery's validity check and
  // the adequacy check's split-record comparison leave such parameters out.
  bool periodic = false;
  // A share, in [0, 1] (two_mass's load_damping_share): its range is its physical domain, so
  // an estimate on an end is a finding (all of it on one side), not the search box deciding;
  // configs are refused outside it, and its interval is judged against the range's width.
  bool share = false;
  const std::string& config_key() const { return key.empty() ? name : key; }
};

// Ordered name -> value map. Small (tens of entries): linear look-up is fine,
// and never used inside a simulation's inner loop.
class ParameterSet {
 public:
  bool Has(std::string_view name) const;
  // Throws std::out_of_range naming the parameter when absent.
  double Get(std::string_view name) const;
  double GetOr(std::string_view name, double fallback) const;
  void Set(const std::string& name, double value);
  const std::vector<std::pair<std::string, double>>& entries() const { return entries_; }

 private:
  std::vector<std::pair<std::string, double>> entries_;
};

}  // namespace blmd
