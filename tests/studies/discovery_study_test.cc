// Discovery under coloured noise (docs/discovery.md): random DC servos (the
// motors of tests/studies/uncertainty_study_test.cc), a +-12 V square wave, 1 % AR(1) noise with
// coefficient 0.95 on i and w. Controls (no hidden effect) must end with nothing added;
// traces with a hidden effect at 6-15 % of the torque (or voltage) scale must still name it
// first. Each trace is also examined with the plain BIC of earlier versions (every sample
// independent), the baseline, printed beside. STUDY_CONTROLS / STUDY_CASES override the
// counts (defaults 40 and 40).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "blmd/ident/discovery/discovery.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/ident/residual/evidence.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"
#include "support/random_motor.h"

namespace blmd::testing {
namespace {

// The hidden effect of case k (cycling through the vocabulary), at 6-15 % of its scale.
std::string HiddenEffect(int k, const Motor& m, Random& random, std::string* name) {
  const double fraction = 0.06 + 0.09 * random.Uniform();
  const double stall = m.K * 12.0 / m.R;                        // N·m
  const double no_load = 12.0 * m.K / (m.K * m.K + m.R * m.B);  // rad/s
  char text[256];
  switch (k % 5) {
    case 0:
      *name = "coulomb_friction";
      std::snprintf(text, sizeof text, R"("coulomb_friction": { "Tc": %.17g })", fraction * stall);
      break;
    case 1:
      *name = "load_torque";
      std::snprintf(text, sizeof text, R"("load_torque": { "TL": %.17g })", fraction * stall);
      break;
    case 2:
      *name = "quadratic_drag";
      std::snprintf(text, sizeof text, R"("quadratic_drag": { "Cd": %.17g })",
                    fraction * stall / (no_load * no_load));
      break;
    case 3:
      *name = "cogging";
      std::snprintf(text, sizeof text,
                    R"("cogging": { "Tcog": %.17g, "periods": %d, "phase": 0.3 })",
                    fraction * stall, 6 + 2 * static_cast<int>(3.0 * random.Uniform()));
      break;
    default:
      *name = "dead_time";
      std::snprintf(text, sizeof text, R"("dead_time": { "Vdt": %.17g })", fraction * 12.0);
      break;
  }
  return text;
}

// Fits J, B and runs discovery; returns the effects added, in order. `prewhiten` false:
// the plain BIC of earlier versions (the baseline).
std::vector<std::string> Discover(const Config& fit_config, FitTrace trace, bool prewhiten = true,
                                  bool* unexplained = nullptr) {
  std::vector<FitTrace> traces;
  traces.push_back(std::move(trace));
  const FitProblem problem(fit_config, std::move(traces), {"i", "w"},
                           MakeFreeParameters(fit_config, {"J", "B"}));
  OptimizerOptions options;
  options.threads = 2;
  const FitResult fit = FindOptimizer("ceres").Minimize(problem, options);
  DiscoveryOptions discovery;
  discovery.refit.threads = 2;
  discovery.prewhiten = prewhiten;
  const DiscoveryResult result = blmd::Discover(problem, fit, discovery);
  if (unexplained) *unexplained = result.adequacy.ok && !result.adequacy.flagged.empty();
  if (unexplained && *unexplained) {
    for (const auto& t : result.adequacy.flagged)
      std::printf("  flagged %s %s share %.3f p %.3g ar %d\n", t.column.c_str(),
                  t.Describe().c_str(), t.share, t.p_value, t.ar_order);
  }
  return result.added;
}

// The evidence the true model itself has, the bound no discovery rule can beat: the truth's
// structure refit from the true values (J, B and the effect's own parameters free, cogging's
// periods fixed), scored by the prewhitened evidence (docs/discovery.md §3a) against the first
// fit (J and B only). When it does not fall below -margin, no rule that keeps the controls
// clean at this margin could add the effect from this trace: the effect is present but not
// identifiable in it (e.g. a cogging torque whose ripple the shaft's inertia filters below
// the noise, or a shaft that turns less than one cogging period, where the torque is a load).
double OracleDeltaBic(const Config& truth, const Config& fit_config, const std::string& effect,
                      const FitTrace& trace) {
  std::vector<std::string> names = {"J", "B"};
  if (effect == "coulomb_friction") names.push_back("Tc");
  if (effect == "load_torque") names.push_back("TL");
  if (effect == "quadratic_drag") names.push_back("Cd");
  if (effect == "cogging") names.insert(names.end(), {"Tcog", "phase"});
  if (effect == "dead_time") names.push_back("Vdt");
  std::vector<FreeParameter> free = MakeFreeParameters(truth, names);
  for (auto& parameter : free) parameter.initial = truth.parameters.Get(parameter.name);
  OptimizerOptions options;
  options.threads = 2;
  const FitProblem base(fit_config, {trace}, {"i", "w"},
                        MakeFreeParameters(fit_config, {"J", "B"}));
  const FitResult base_fit = FindOptimizer("ceres").Minimize(base, options);
  std::vector<double> base_residuals;
  base.Evaluate(base_fit.values, &base_residuals);
  const FitProblem oracle(truth, {trace}, {"i", "w"}, free);
  const FitResult fit = FindOptimizer("ceres").Minimize(oracle, options);
  const WhitenedEvidence evidence = PrewhitenedEvidence(base_residuals, 2, oracle, fit.values);
  EXPECT_TRUE(evidence.ok) << evidence.reason;
  return evidence.delta_bic;
}

// " a b" for effects {a, b}, " nothing" for none.
std::string Listed(const std::vector<std::string>& effects) {
  std::string out;
  for (const auto& e : effects) out += " " + e;
  return effects.empty() ? " nothing" : out;
}

int Count(const char* variable, int fallback) {
  return std::getenv(variable) ? std::atoi(std::getenv(variable)) : fallback;
}

TEST(DiscoveryUnderColouredNoise, ControlsAddNothing) {
  const int controls = Count("STUDY_CONTROLS", 40);
  int clean = 0, plain_clean = 0, flagged = 0;
  for (int seed = 1; seed <= controls; ++seed) {
    Random random(static_cast<std::uint64_t>(seed) * 104729u);
    const Motor motor = RandomMotor(random);
    const Config config = MotorConfig(motor, "", "control.json");
    const FitTrace trace = ColouredNoiseTrace(config, random, 0.95);
    bool unexplained = false;
    const std::vector<std::string> added = Discover(config, trace, true, &unexplained);
    flagged += unexplained;
    const std::vector<std::string> plain = Discover(config, trace, false);
    std::printf("control %d: added%s (plain BIC:%s)\n", seed, Listed(added).c_str(),
                Listed(plain).c_str());
    clean += added.empty();
    plain_clean += plain.empty();
  }
  std::printf("AR(1) 0.95 controls with nothing added: %d/%d (plain BIC: %d/%d)\n", clean, controls,
              plain_clean, controls);
  // The adequacy check's false alarms on strongly coloured noise (docs/discovery.md §7).
  std::printf("AR(1) 0.95 controls flagged unexplained_structure: %d/%d\n", flagged, controls);
  EXPECT_GE(clean, 0.95 * controls);
  EXPECT_LE(flagged, 0.05 * controls);
}

TEST(DiscoveryUnderColouredNoise, HiddenEffectsAreStillNamedFirst) {
  const int cases = Count("STUDY_CASES", 40);
  int named = 0, plain_named = 0;
  int identifiable_cases = 0, identifiable_named = 0, unidentifiable_named = 0;
  for (int k = 0; k < cases; ++k) {
    Random random(static_cast<std::uint64_t>(k + 1) * 15485863u);
    const Motor motor = RandomMotor(random);
    std::string effect;
    const std::string hidden = HiddenEffect(k, motor, random, &effect);
    const Config truth = MotorConfig(motor, hidden, "truth.json");
    const Config fit_config = MotorConfig(motor, "", "fit.json");
    const FitTrace trace = ColouredNoiseTrace(truth, random, 0.95);
    const std::vector<std::string> added = Discover(fit_config, trace);
    const std::vector<std::string> plain = Discover(fit_config, trace, false);
    const double oracle = OracleDeltaBic(truth, fit_config, effect, trace);
    const bool identifiable = oracle < -DiscoveryOptions().bic_margin;
    const bool first = !added.empty() && added.front() == effect;
    std::printf("case %d (%s): added%s (plain BIC:%s); the true model's evidence %.1f%s\n", k,
                effect.c_str(), Listed(added).c_str(), Listed(plain).c_str(), oracle,
                identifiable ? "" : " (not identifiable)");
    named += first;
    plain_named += !plain.empty() && plain.front() == effect;
    identifiable_cases += identifiable;
    identifiable_named += identifiable && first;
    unidentifiable_named += !identifiable && first;
  }
  std::printf("AR(1) 0.95 hidden effect named first: %d/%d (plain BIC: %d/%d)\n", named, cases,
              plain_named, cases);
  std::printf(
      "cases whose true model clears the margin: %d/%d, named first in %d of them; "
      "named first where it does not: %d\n",
      identifiable_cases, cases, identifiable_named, unidentifiable_named);
  // Measured (40 cases): 29 named first, the plain BIC 30. The bar is 80 %. Seven of
  // the 40 effects are not identifiable from their trace: the true model, refit from the
  // truth, does not clear the margin (five drags, ΔBIC -5.5 ... +5.3; two coggings filtered
  // by the inertia, +8.3 and +25.4). Of the 33 that are, 29 are named first (88 %); the
  // misses are three coggings on shafts that turn less than half a revolution (over such a
  // span a cogging torque is a load torque: load_torque is added on two) and a drag at -18.
  EXPECT_GE(named, 0.7 * cases);
  EXPECT_GE(identifiable_named, 0.8 * identifiable_cases);
  EXPECT_GE(named, plain_named - 1);
}

}  // namespace
}  // namespace blmd::testing
