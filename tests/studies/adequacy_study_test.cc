// The measuring instrument of model adequacy and the spring and gravity effects: random DC servos
// simulated by an independent simulator (tests/support/independent_servo.h, written from the
// equations, sharing no code with src/), each with an effect of 6-15 % of its stall torque
// K*12/R, identified by the real `blmd-ident --discover --json` from a config that declares
// no effect (J x1.5 and B x0.7 off at the start, J and B free, i and w observed). Per kind a
// table: what discovery added (first, in order; cogging with its order), the final model's J
// and B errors, the report's warning codes, NRMSE before -> after, wall time. The issue's
// Show bars are EXPECTs, so a run reports every one that fails.
//
// Kinds (STUDY_CASES per kind, default 6; the earlier kinds STUDY_EARLIER each, default 6):
//   spring            Ks (theta - theta0), the shaft swinging 0.25-10 rev peak to peak, theta0
//                     uniform over the spring-free record's angle range, Ks so that
//                     Ks * (that range) is 6-15 % of stall
//   gravity_turning   Tg sin(theta + phi), the shaft turning 2-60 rev peak to peak
//   gravity_swinging  the same swinging 0.5-0.9 rev peak to peak
//   disturbance       Td sin(2 pi f t + psi), f 2-6 Hz, a record of at least 1.5 s (3 cycles)
//   coulomb_cogging   Coulomb friction and cogging of 6, 6, 8, 8, 12, 12 periods/rev, 2-60 rev
//   earlier           coulomb_friction, load_torque, quadratic_drag, cogging, dead_time, none
// Motors: R, L, K, J, B as tests/support/random_motor.h (log-uniform over the same ranges),
// redrawn until B/(B + K^2/R) >= 0.1 (viscous damping at least 10 % of the total, so B is
// identifiable) and until the kind's timing fits (below). Input: +-12 V square wave, +12
// first, two periods, 6001 samples (1500 per half period), period 8 tau_m unless the kind
// asks for an angle range (then the period in [4, 16] tau_m that gives a range drawn
// log-uniformly in the kind's band) or a long record (disturbance: max(8 tau_m, 0.75 s) if
// that is at most 16 tau_m). Noise: 1 % of each column's RMS on i and w (white, seeded).
// Tool numerics: simulation.dt = 1/(4 fs), as the random motors of the other studies.
//
// Every trace, config and report is kept in <build>/adequacy-study/ (kind-k.csv, .json,
// .report.json, .oracle.json) and the tables in adequacy-study/summary-<kind>.tsv, to rerun
// a case by hand:
//   build/bin/blmd-ident --config build/adequacy-study/spring-0.json
//     --trace build/adequacy-study/spring-0.csv --discover   (one line)
// STUDY_SEED=n draws another set of cases (default 0: the tables below).
// STUDY_KINDS=spring,disturbance restricts the kinds; STUDY_THREADS (default 1) is passed
// to --threads; STUDY_BIN_DIR=other/build/bin measures another build's commands and
// STUDY_OUT_DIR puts the files elsewhere.
//
// The oracle column: the same trace fitted with the truth's structure declared (its effect
// parameters, J and B free from their true values, cogging's periods fixed), no discovery:
// what a perfect discovery would give at the tool's numerics and this noise. (From J x1.5,
// B x0.7 a free-running cogging fit lands in a wrong basin: J +41 %, B -37 %, NRMSE 0.18 on
// coulomb_cogging 0; docs/discovery.md section 6 says why.) n/a for the
// disturbance (no name) and for effects the tool refuses (spring and gravity before it modelled
// them). STUDY_ORACLE=0 skips it.
//
// A second test checks the instrument itself: noise-free records of the independent
// simulator against `blmd-sim --input` of the same truth (each effect the tool knows),
// the worst deviation relative to the column's peak.
//
// Baseline, main at f8e2175 before the adequacy check, spring and gravity (2026-11-27, 2 shared
// cores, --threads 1; the whole binary 5 min 20 s wall, 2.5 min CPU; 1-10 s per blmd-ident
// --discover):
//   spring            spring first 0/6 (cogging of order 2-53, load, drag first); median worse
//                     of |J|, |B| error 6.5 % (B -47 % on two)
//   gravity_turning   gravity first 0/6, but cogging(1), the same torque, first 6/6, nothing
//                     after it; J, B within 0.08 % (median 0.06 %); no warning
//   gravity_swinging  gravity first 0/6 (load_torque or cogging(2) first, 2-3 effects); median
//                     worse error 9.5 %
//   disturbance       nothing added 6/6, median |B error| 0.17 %, residual_not_white 6/6,
//                     unexplained_structure 0/6 (the code does not exist yet)
//   coulomb_cogging   right 0/6: Coulomb and a cogging of the wrong order (20, 40) on 2,
//                     Coulomb alone on 1, stribeck first on 3 (with 59/rev, 18/rev, and the
//                     right 12/rev but no Coulomb); median |B error| 10.5 % (B +55, +26, +18 %
//                     where stribeck is added); the oracle fits B within 0.7 %
//   earlier           right first 32/36 (the four misses are coggings, wrong order: 13, 3,
//                     15, 3; the oracle fits them to the noise), unexplained_structure 0/32
//   instrument        single effects agree with blmd-sim to <= 4e-4 of the peak
// main's build/bin of 04:58 (the adequacy check of 2d68c81, no spring or gravity): disturbance
// unexplained_structure 5/6 (the miss: Td 6.6 %, NRMSE at the noise floor), nothing added,
// median |B| 0.17 % (bar met); earlier right first 34/36, unexplained_structure where found
// 1/34 (bar met); coulomb_cogging right 1/6 (Coulomb alone on 4, Coulomb + load on 1; no
// stribeck), median |B| 2.4 %; gravity_turning no longer finds cogging(1): load, cogging(5,
// 37, 58) or nothing, median worse error 2.2 % (was 0.06 %); spring 0/6, swinging 0/6, with
// unexplained_structure on 12 of those 12.
// Preview, branch pos at 3bc819e (spring and gravity, STUDY_BIN_DIR): spring first 6/6,
// gravity first 6/6 turning and 6/6 swinging, nothing after them, median worse error 0.04 %,
// 0.06 %, 0.06 % (bars met); the independent simulator agrees with its blmd-sim on spring and
// gravity to 6e-5 of the peak; coulomb_cogging adds gravity on 2 of 6 (with Coulomb, and after
// a stribeck); disturbance and the earlier kinds as main (earlier 33/36).
// main after the Nyquist order in angle, the equal-size held-out rule and eight refit orders
// (2026-11-27, second session): spring, gravity turning, swinging 6/6 (0.04, 0.06, 0.06 %);
// disturbance nothing added, unexplained_structure 5/6, B 0.17 %; coulomb_cogging 6/6, B 0.35 %
// (STUDY_SEED=1, 2: 5/6 each, the miss a cogging that Coulomb alone fits to the oracle's
// NRMSE); earlier 36/36, unexplained_structure 0/36.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "support/independent_servo.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

using independent::Extras;
using independent::Record;
using independent::Servo;
using Json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
constexpr double kVolts = 12.0;
constexpr std::size_t kHalf = 1500;              // samples per half period
constexpr std::size_t kSamples = 4 * kHalf + 1;  // two periods, both ends

int Count(const char* variable, int fallback) {
  const char* text = std::getenv(variable);
  return text && *text ? std::atoi(text) : fallback;
}

struct Draw {
  explicit Draw(std::uint64_t seed) : engine(seed) {}
  double Uniform(double lo = 0.0, double hi = 1.0) {
    return lo + (hi - lo) * (static_cast<double>(engine() >> 11) * 0x1.0p-53);
  }
  double LogUniform(double lo, double hi) { return lo * std::pow(hi / lo, Uniform()); }
  std::mt19937_64 engine;
};

double TauM(const Servo& m) { return m.J * m.R / (m.K * m.K + m.R * m.B); }
double Stall(const Servo& m) { return m.K * kVolts / m.R; }
double NoLoadSpeed(const Servo& m) { return kVolts * m.K / (m.K * m.K + m.R * m.B); }

// A random DC servo (tests/support/random_motor.h's ranges) whose viscous damping is at least
// 10 % of its total damping B + K^2/R.
Servo DrawServo(Draw& draw) {
  for (;;) {
    Servo m;
    m.R = draw.LogUniform(0.5, 20.0);
    m.L = m.R * draw.LogUniform(2e-4, 5e-3);
    m.K = draw.LogUniform(0.02, 0.3);
    m.J = draw.LogUniform(1e-6, 1e-3);
    m.B = draw.LogUniform(1e-6, 1e-3);
    if (m.B >= 0.1 * (m.B + m.K * m.K / m.R)) return m;
  }
}

Record Simulate(const Servo& m, const Extras& e, double period) {
  const double fs = 2.0 * kHalf / period;
  return independent::Simulate(m, e, independent::SquareWave(kSamples, kHalf, kVolts), fs,
                               Count("STUDY_SUBSTEPS", 64));
}

double RangeRev(const Record& r) { return independent::PeakToPeak(r.theta) / (2.0 * kPi); }

struct Case {
  std::string kind, truth;  // truth: the effects in it, e.g. "coulomb_friction+cogging"
  int periods = 0;          // the cogging order, if any
  int k = 0;
  Servo m;
  Extras e;
  double period = 0.0, fs = 0.0, range_rev = 0.0;
  std::string size;  // the effect's size, in words
  Record record;     // noisy
  std::uint64_t seed = 0;
};

// The period in [4, 16] tau_m whose effect-free record turns through a range drawn
// log-uniformly in [lo_rev, hi_rev]; 0 when no period there reaches the band.
double PeriodForRange(const Servo& m, double lo_rev, double hi_rev, Draw& draw) {
  const double tau = TauM(m);
  const double r_lo = RangeRev(Simulate(m, {}, 4.0 * tau));
  const double r_hi = RangeRev(Simulate(m, {}, 16.0 * tau));
  const double lo = std::max(lo_rev, r_lo), hi = std::min(hi_rev, r_hi);
  if (!(lo < hi)) return 0.0;
  const double target = draw.LogUniform(lo, hi);
  double a = std::log(4.0 * tau), b = std::log(16.0 * tau);
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (a + b);
    (RangeRev(Simulate(m, {}, std::exp(mid))) < target ? a : b) = mid;
  }
  return std::exp(0.5 * (a + b));
}

const std::vector<std::string>& EarlierKinds() {
  static const std::vector<std::string> kinds = {
      "coulomb_friction", "load_torque", "quadratic_drag", "cogging", "dead_time", "none"};
  return kinds;
}

// Case k of `kind` ("earlier" cycles through EarlierKinds()). Redraws the motor until the
// kind's timing and angle band are met by the record with the effect in it.
Case MakeCase(const std::string& kind, int k) {
  static const std::map<std::string, std::uint64_t> salt = {
      {"spring", 1},      {"gravity_turning", 2}, {"gravity_swinging", 3},
      {"disturbance", 4}, {"coulomb_cogging", 5}, {"earlier", 6}};
  Case c;
  c.kind = kind;
  c.k = k;
  // STUDY_SEED (default 0) draws another set of cases: a held-out set for rules tuned on
  // the default one.
  const auto set = static_cast<std::uint64_t>(Count("STUDY_SEED", 0));
  Draw draw(salt.at(kind) * 1000003u + static_cast<std::uint64_t>(k) * 7919u + 17u +
            set * 0x9E3779B97F4A7C15u);
  char text[256];
  for (int attempt = 0; attempt < 10000; ++attempt) {
    c.m = DrawServo(draw);
    c.e = Extras{};
    const double tau = TauM(c.m), stall = Stall(c.m);
    const double fraction = draw.Uniform(0.06, 0.15);
    c.period = 8.0 * tau;
    double lo_rev = 0.0, hi_rev = 1e300;  // the band the record with the effect must meet
    if (kind == "spring") {
      c.truth = "spring";
      lo_rev = 0.25;
      hi_rev = 10.0;
      c.period = PeriodForRange(c.m, lo_rev, hi_rev, draw);
      if (c.period == 0.0) continue;
      const Record free = Simulate(c.m, {}, c.period);
      const auto [lo, hi] = std::minmax_element(free.theta.begin(), free.theta.end());
      c.e.theta0 = draw.Uniform(*lo, *hi);
      c.e.Ks = fraction * stall / (*hi - *lo);
      std::snprintf(text, sizeof text, "K=%.3g theta0=%.3g (%.1f %% over the range)", c.e.Ks,
                    c.e.theta0, 100 * fraction);
    } else if (kind == "gravity_turning" || kind == "gravity_swinging") {
      c.truth = "gravity";
      const bool turning = kind == "gravity_turning";
      lo_rev = turning ? 2.0 : 0.5;
      hi_rev = turning ? 60.0 : 0.9;
      c.period = PeriodForRange(c.m, lo_rev, hi_rev, draw);
      if (c.period == 0.0) continue;
      c.e.Tg = fraction * stall;
      c.e.gravity_phase = draw.Uniform(-kPi, kPi);
      std::snprintf(text, sizeof text, "Tg=%.3g (%.1f %%) phase=%.2f", c.e.Tg, 100 * fraction,
                    c.e.gravity_phase);
    } else if (kind == "disturbance") {
      c.truth = "disturbance";
      c.period = std::max(8.0 * tau, 0.75);
      if (c.period > 16.0 * tau) continue;
      c.e.Td = fraction * stall;
      c.e.disturbance_hz = draw.Uniform(2.0, 6.0);
      c.e.disturbance_phase = draw.Uniform(-kPi, kPi);
      std::snprintf(text, sizeof text, "Td=%.3g (%.1f %%) f=%.2f Hz", c.e.Td, 100 * fraction,
                    c.e.disturbance_hz);
    } else if (kind == "coulomb_cogging") {
      c.truth = "coulomb_friction+cogging";
      static const int orders[] = {6, 8, 12};
      c.periods = orders[(k / 2) % 3];
      lo_rev = 2.0;
      hi_rev = 60.0;
      c.period = PeriodForRange(c.m, lo_rev, hi_rev, draw);
      if (c.period == 0.0) continue;
      const double fraction2 = draw.Uniform(0.06, 0.15);
      c.e.Tc = fraction * stall;
      c.e.Tcog = fraction2 * stall;
      c.e.cog_periods = c.periods;
      c.e.cog_phase = draw.Uniform(-kPi, kPi);
      std::snprintf(text, sizeof text, "Tc %.1f %%, Tcog %.1f %% %d/rev", 100 * fraction,
                    100 * fraction2, c.periods);
    } else {  // earlier
      c.truth = EarlierKinds()[static_cast<std::size_t>(k) % EarlierKinds().size()];
      if (c.truth == "coulomb_friction") {
        c.e.Tc = fraction * stall;
      } else if (c.truth == "load_torque") {
        c.e.TL = (draw.Uniform() < 0.5 ? -1.0 : 1.0) * fraction * stall;
      } else if (c.truth == "quadratic_drag") {
        c.e.Cd = fraction * stall / (NoLoadSpeed(c.m) * NoLoadSpeed(c.m));
      } else if (c.truth == "cogging") {
        static const int orders[] = {6, 8, 12};
        c.periods = orders[static_cast<int>(3.0 * draw.Uniform()) % 3];
        lo_rev = 2.0;
        hi_rev = 60.0;
        c.period = PeriodForRange(c.m, lo_rev, hi_rev, draw);
        if (c.period == 0.0) continue;
        c.e.Tcog = fraction * stall;
        c.e.cog_periods = c.periods;
        c.e.cog_phase = draw.Uniform(-kPi, kPi);
      } else if (c.truth == "dead_time") {
        c.e.Vdt = fraction * kVolts;
      }
      std::snprintf(text, sizeof text, "%.1f %%%s", c.truth == "none" ? 0.0 : 100 * fraction,
                    c.periods ? (" " + std::to_string(c.periods) + "/rev").c_str() : "");
    }
    c.size = text;
    c.fs = 2.0 * kHalf / c.period;
    c.record = Simulate(c.m, c.e, c.period);
    c.range_rev = RangeRev(c.record);
    // The band with 5 % slack for the effect's own pull on the range.
    if (c.range_rev < 0.95 * lo_rev || c.range_rev > 1.05 * hi_rev) continue;
    bool finite = true;
    for (double v : c.record.w) finite = finite && std::isfinite(v);
    if (!finite) continue;
    c.seed = salt.at(kind) * 7777u + static_cast<std::uint64_t>(k) + set * 0x9E3779B97F4A7C15u;
    independent::AddNoise(&c.record, 0.01, c.seed);
    return c;
  }
  ADD_FAILURE() << kind << " " << k << ": no motor met the kind's timing in 10000 draws";
  return c;
}

// The fit config: the true R, L, K; J and B off (x1.5, x0.7) and free; no effect declared.
// `extra_free`: more free parameters (the oracle's effect parameters), ", \"Tc\"" etc.
std::string FitConfig(const Case& c, const std::string& effects = "", bool truth_jb = false,
                      double steps_per_sample = 4.0, const std::string& extra_free = "") {
  const double J0 = truth_jb ? c.m.J : 1.5 * c.m.J, B0 = truth_jb ? c.m.B : 0.7 * c.m.B;
  char text[4096];
  std::snprintf(text, sizeof text, R"({
  "name": "adequacy-%s-%d", "model": "dc_servo",
  "parameters": { "R": %.17g, "L": %.17g, "Kt": %.17g, "Kb": %.17g, "J": %.17g, "B": %.17g },
  "effects": { %s },
  "simulation": { "dt": %.17g },
  "experiment": { "input": { "type": "square", "amplitude": 12.0, "period": %.17g },
                  "duration": %.17g, "sample_rate": %.17g },
  "identification": { "free": ["J", "B"%s], "initial": { "J": %.17g, "B": %.17g },
                      "bounds": { "J": [%.17g, %.17g], "B": [%.17g, %.17g] },
                      "observe": ["i", "w"], "method": "ceres" }
}
)",
                c.kind.c_str(), c.k, c.m.R, c.m.L, c.m.K, c.m.K, J0, B0, effects.c_str(),
                1.0 / (steps_per_sample * c.fs), c.period, 2.0 * c.period, c.fs, extra_free.c_str(),
                J0, B0, J0 / 100, J0 * 100, B0 / 100, B0 * 100);
  return text;
}

// The truth's effects in the tool's vocabulary (spring and gravity as the interface names
// them; a disturbance has no name).
std::string TruthEffects(const Extras& e) {
  std::vector<std::string> parts;
  char text[256];
  if (e.Tc > 0) {
    std::snprintf(text, sizeof text, R"("coulomb_friction": { "Tc": %.17g })", e.Tc);
    parts.push_back(text);
  }
  if (e.TL != 0) {
    std::snprintf(text, sizeof text, R"("load_torque": { "TL": %.17g })", e.TL);
    parts.push_back(text);
  }
  if (e.Cd > 0) {
    std::snprintf(text, sizeof text, R"("quadratic_drag": { "Cd": %.17g })", e.Cd);
    parts.push_back(text);
  }
  if (e.Tcog > 0) {
    std::snprintf(text, sizeof text,
                  R"("cogging": { "Tcog": %.17g, "periods": %.17g, "phase": %.17g })", e.Tcog,
                  e.cog_periods, e.cog_phase);
    parts.push_back(text);
  }
  if (e.Vdt > 0) {
    std::snprintf(text, sizeof text, R"("dead_time": { "Vdt": %.17g })", e.Vdt);
    parts.push_back(text);
  }
  if (e.Ks > 0) {
    std::snprintf(text, sizeof text, R"("spring": { "K": %.17g, "theta0": %.17g })", e.Ks,
                  e.theta0);
    parts.push_back(text);
  }
  if (e.Tg > 0) {
    std::snprintf(text, sizeof text, R"("gravity": { "Tg": %.17g, "phase": %.17g })", e.Tg,
                  e.gravity_phase);
    parts.push_back(text);
  }
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

// The truth's effect parameters, free in the oracle (cogging's periods fixed).
std::string TruthFree(const Extras& e) {
  std::string out;
  if (e.Tc > 0) out += ", \"Tc\"";
  if (e.TL != 0) out += ", \"TL\"";
  if (e.Cd > 0) out += ", \"Cd\"";
  if (e.Tcog > 0) out += ", \"Tcog\", \"phase\"";
  if (e.Vdt > 0) out += ", \"Vdt\"";
  if (e.Ks > 0) out += ", \"K\", \"theta0\"";
  if (e.Tg > 0) out += ", \"Tg\", \"gravity_phase\"";  // cogging owns the flat "phase"
  return out;
}

// The command under test: this build's (BinPath), or STUDY_BIN_DIR's, to measure another
// build's binaries (a branch's) with the same instrument without rebuilding it.
std::string Tool(const std::string& command) {
  const char* dir = std::getenv("STUDY_BIN_DIR");
  return dir && *dir ? std::string(dir) + "/" + command : BinPath(command);
}

std::string StudyDir() {
  const char* out = std::getenv("STUDY_OUT_DIR");
  const std::string dir =
      out && *out ? std::string(out) : std::string(BLMD_BIN_DIR) + "/../adequacy-study";
  std::filesystem::create_directories(dir);
  return dir;
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

struct Outcome {
  int exit_code = -1;
  std::string error;
  std::vector<std::string> added;  // cogging as "cogging(m)"
  std::vector<std::string> warnings;
  int cogging_periods = 0;
  double J_err = NAN, B_err = NAN, nrmse_before = NAN, nrmse_after = NAN, wall_s = NAN;
  // The oracle: the truth's structure declared (every free parameter from the truth), no
  // discovery; "n/a" when there is no truth to declare
  // (the disturbance) or the tool refuses it (oracle_note says why).
  double oracle_J_err = NAN, oracle_B_err = NAN, oracle_nrmse = NAN;
  std::string oracle_note;
  bool Added(const std::string& effect) const {
    return std::any_of(added.begin(), added.end(),
                       [&](const std::string& a) { return a.rfind(effect, 0) == 0; });
  }
  bool First(const std::string& effect) const {
    return !added.empty() && added.front().rfind(effect, 0) == 0;
  }
  bool Warned(const std::string& code) const {
    return std::find(warnings.begin(), warnings.end(), code) != warnings.end();
  }
  double Worse() const { return std::max(std::abs(J_err), std::abs(B_err)); }
};

void Oracle(const Case& c, const std::string& base, Outcome* o) {
  const std::string effects = TruthEffects(c.e);
  if (effects.empty() && c.e.Td != 0) {
    o->oracle_note = "no name";
    return;
  }
  if (!Count("STUDY_ORACLE", 1)) return;
  WriteFile(base + ".oracle.json", FitConfig(c, effects, true, 4.0, TruthFree(c.e)));
  const CommandResult run =
      blmd::testing::Run(Tool("blmd-ident") + " --config " + base + ".oracle.json --trace " + base +
                         ".csv --json --threads " + std::to_string(Count("STUDY_THREADS", 1)));
  if (run.exit_code != 0) {
    o->oracle_note = "exit " + std::to_string(run.exit_code);
    if (run.err.find("unknown effect") != std::string::npos) o->oracle_note = "unknown effect";
    return;
  }
  try {
    const Json report = Json::parse(run.out);
    o->oracle_J_err = report["parameters"]["J"]["value"].get<double>() / c.m.J - 1.0;
    o->oracle_B_err = report["parameters"]["B"]["value"].get<double>() / c.m.B - 1.0;
    o->oracle_nrmse = report["fit"].value("nrmse", NAN);
  } catch (const std::exception& error) {
    o->oracle_note = "bad report";
  }
}

Outcome RunDiscovery(const Case& c) {
  const std::string base = StudyDir() + "/" + c.kind + "-" + std::to_string(c.k);
  WriteFile(base + ".csv", independent::Csv(c.record));
  WriteFile(base + ".json", FitConfig(c));
  Outcome o;
  const auto start = std::chrono::steady_clock::now();
  const CommandResult run =
      Run(Tool("blmd-ident") + " --config " + base + ".json --trace " + base +
          ".csv --discover --json --threads " + std::to_string(Count("STUDY_THREADS", 1)));
  o.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  o.exit_code = run.exit_code;
  if (run.exit_code != 0) {
    o.error = run.err.substr(0, run.err.find('\n'));
    return o;
  }
  WriteFile(base + ".report.json", run.out);
  Json report;
  try {
    report = Json::parse(run.out);
  } catch (const std::exception& error) {
    o.error = std::string("report is not JSON: ") + error.what();
    return o;
  }
  o.J_err = report["parameters"]["J"]["value"].get<double>() / c.m.J - 1.0;
  o.B_err = report["parameters"]["B"]["value"].get<double>() / c.m.B - 1.0;
  if (report.contains("warnings")) {
    for (const auto& w : report["warnings"]) o.warnings.push_back(w.value("code", "?"));
  }
  const Json& d = report["discovery"];
  for (const auto& step : d.value("steps", Json::array())) {
    std::string name = step.value("effect", "?");
    if (name == "cogging" && step.contains("parameters") &&
        step["parameters"].contains("periods")) {
      const int periods =
          static_cast<int>(std::lround(step["parameters"]["periods"].get<double>()));
      if (o.cogging_periods == 0) o.cogging_periods = periods;
      name += "(" + std::to_string(periods) + ")";
    }
    o.added.push_back(name);
  }
  if (o.added.empty()) {  // steps missing: fall back on the names
    for (const auto& a : d.value("added", Json::array())) o.added.push_back(a.get<std::string>());
  }
  if (d.contains("error_before")) o.nrmse_before = d["error_before"].value("nrmse", NAN);
  if (report.contains("fit")) o.nrmse_after = report["fit"].value("nrmse", NAN);
  Oracle(c, base, &o);
  return o;
}

std::string Joined(const std::vector<std::string>& items, const char* empty) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ",") + s;
  return out.empty() ? empty : out;
}

double Median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

bool KindSelected(const std::string& kind) {
  const char* kinds = std::getenv("STUDY_KINDS");
  if (!kinds || !*kinds) return true;
  std::stringstream list(kinds);
  for (std::string item; std::getline(list, item, ',');) {
    if (item == kind) return true;
  }
  return false;
}

// Runs the kind's cases and prints its table; returns the outcomes.
std::vector<std::pair<Case, Outcome>> RunKind(const std::string& kind, int cases) {
  std::vector<std::pair<Case, Outcome>> rows;
  std::printf("\n== %s (%d cases) ==\n", kind.c_str(), cases);
  std::printf("%-3s %-26s %8s %7s %-34s %-40s %8s %8s %-44s %-15s %6s  %s\n", "k", "truth", "tau_m",
              "rev", "size", "added", "J err%", "B err%", "warnings", "nrmse", "time",
              "oracle: J err% B err% nrmse");
  // One table per kind: ctest runs each kind in its own process.
  std::ofstream tsv(StudyDir() + "/summary-" + kind + ".tsv");
  tsv << "kind\tk\ttruth\ttau_m\trange_rev\tsize\tadded\tJ_err\tB_err\twarnings\tnrmse_before\t"
         "nrmse_after\twall_s\texit\toracle_J_err\toracle_B_err\toracle_nrmse\toracle_note\n";
  for (int k = 0; k < cases; ++k) {
    Case c = MakeCase(kind, k);
    const Outcome o = RunDiscovery(c);
    char nrmse[64];
    std::snprintf(nrmse, sizeof nrmse, "%.4f->%.4f", o.nrmse_before, o.nrmse_after);
    char oracle[96];
    if (o.oracle_note.empty()) {
      std::snprintf(oracle, sizeof oracle, "%8.2f %8.2f %.4f", 100 * o.oracle_J_err,
                    100 * o.oracle_B_err, o.oracle_nrmse);
    } else {
      std::snprintf(oracle, sizeof oracle, "n/a (%s)", o.oracle_note.c_str());
    }
    std::printf("%-3d %-26s %8.3g %7.2f %-34s %-40s %8.2f %8.2f %-44s %-15s %6.1f  %s%s%s\n", k,
                c.truth.c_str(), TauM(c.m), c.range_rev, c.size.c_str(),
                Joined(o.added, "nothing").c_str(), 100 * o.J_err, 100 * o.B_err,
                Joined(o.warnings, "-").c_str(), nrmse, o.wall_s, oracle,
                o.exit_code ? (" exit " + std::to_string(o.exit_code) + ": ").c_str() : "",
                o.error.c_str());
    std::fflush(stdout);
    tsv << kind << '\t' << k << '\t' << c.truth << '\t' << TauM(c.m) << '\t' << c.range_rev << '\t'
        << c.size << '\t' << Joined(o.added, "nothing") << '\t' << o.J_err << '\t' << o.B_err
        << '\t' << Joined(o.warnings, "-") << '\t' << o.nrmse_before << '\t' << o.nrmse_after
        << '\t' << o.wall_s << '\t' << o.exit_code << '\n';
    EXPECT_EQ(o.exit_code, 0) << kind << " " << k << ": " << o.error;
    rows.emplace_back(std::move(c), o);
  }
  return rows;
}

// "n/N" tallies and the bars.
struct Tally {
  int hits = 0, total = 0;
  std::string Text() const { return std::to_string(hits) + "/" + std::to_string(total); }
  bool AtLeastFiveInSix() const { return 6 * hits >= 5 * total; }
};

class AdequacyStudy : public ::testing::Test {};

// Spring and gravity: named first on >= 5 of 6, the median of the worse of |J err|, |B err|
// within 2 %.
void PositionKind(const std::string& kind, const std::string& effect) {
  if (!KindSelected(kind)) GTEST_SKIP() << "not in STUDY_KINDS";
  const auto rows = RunKind(kind, Count("STUDY_CASES", 6));
  Tally first, order_one;
  std::vector<double> worse;
  for (const auto& [c, o] : rows) {
    first.total++;
    first.hits += o.First(effect);
    // Gravity's torque Tg sin(theta + phase) is cogging of order 1: the same physics under
    // another name, counted apart (the bar asks for the name).
    order_one.hits += !o.added.empty() && o.added.front() == "cogging(1)";
    worse.push_back(o.Worse());
  }
  const double median = Median(worse);
  std::printf(
      "%s: %s named first %s (cogging of order 1 first: %d); median worse of |J|,|B| error "
      "%.2f %%\n",
      kind.c_str(), effect.c_str(), first.Text().c_str(), order_one.hits, 100 * median);
  EXPECT_TRUE(first.AtLeastFiveInSix())
      << kind << ": " << effect << " named first on " << first.Text();
  EXPECT_LE(median, 0.02) << kind << ": median of the worse J/B error";
}

TEST_F(AdequacyStudy, Spring) { PositionKind("spring", "spring"); }
TEST_F(AdequacyStudy, GravityTurning) { PositionKind("gravity_turning", "gravity"); }
TEST_F(AdequacyStudy, GravitySwinging) { PositionKind("gravity_swinging", "gravity"); }

// A disturbance in time has no name in the vocabulary: whatever is added must not distort B
// by more than 5 % (median), and unexplained_structure must be raised on >= 5 of 6.
TEST_F(AdequacyStudy, Disturbance) {
  if (!KindSelected("disturbance")) GTEST_SKIP() << "not in STUDY_KINDS";
  const auto rows = RunKind("disturbance", Count("STUDY_CASES", 6));
  Tally warned;
  std::vector<double> b;
  for (const auto& [c, o] : rows) {
    warned.total++;
    warned.hits += o.Warned("unexplained_structure");
    b.push_back(std::abs(o.B_err));
  }
  const double median = Median(b);
  std::printf("disturbance: unexplained_structure %s; median |B error| %.2f %%\n",
              warned.Text().c_str(), 100 * median);
  EXPECT_LE(median, 0.05) << "disturbance: median |B error|";
  EXPECT_TRUE(warned.AtLeastFiveInSix())
      << "disturbance: unexplained_structure on " << warned.Text();
}

// Coulomb friction with cogging: both named, no stribeck, the right order; B within 2 %
// (median), on >= 5 of 6 (the bar). Measured 4 of 6 before the cogging orders were
// limited to the samples' Nyquist order in angle (62/rev had been added for 8/rev sampled 35
// times per revolution) and before a candidate with as many parameters that predicts the
// held-out blocks better displaced the best by BIC (gravity had been added for a 12/rev
// cogging); 2 of 6 before the position-dependent refits, 0 of 6 at the baseline above.
TEST_F(AdequacyStudy, CoulombWithCogging) {
  if (!KindSelected("coulomb_cogging")) GTEST_SKIP() << "not in STUDY_KINDS";
  const auto rows = RunKind("coulomb_cogging", Count("STUDY_CASES", 6));
  Tally right;
  std::vector<double> b;
  for (const auto& [c, o] : rows) {
    right.total++;
    right.hits += o.Added("coulomb_friction") && o.Added("cogging") && !o.Added("stribeck") &&
                  o.cogging_periods == c.periods;
    b.push_back(std::abs(o.B_err));
  }
  const double median = Median(b);
  std::printf(
      "coulomb_cogging: both named, no stribeck, the right order %s; median |B error| %.2f %%\n",
      right.Text().c_str(), 100 * median);
  EXPECT_TRUE(right.AtLeastFiveInSix()) << "coulomb_cogging: right on " << right.Text();
  EXPECT_LE(median, 0.02) << "coulomb_cogging: median |B error|";
}

// The earlier kinds: the right effect found (for none: nothing added) on >= 5 of 6, and where
// it is, unexplained_structure raised on at most 1 in 6.
TEST_F(AdequacyStudy, EarlierKinds) {
  if (!KindSelected("earlier")) GTEST_SKIP() << "not in STUDY_KINDS";
  const int cases = Count("STUDY_EARLIER", 6) * static_cast<int>(EarlierKinds().size());
  const auto rows = RunKind("earlier", cases);
  Tally found, false_alarm;
  for (const auto& [c, o] : rows) {
    found.total++;
    const bool right = c.truth == "none"
                           ? o.added.empty() && o.exit_code == 0
                           : o.First(c.truth) && (c.periods == 0 || o.cogging_periods == c.periods);
    found.hits += right;
    if (right) {
      false_alarm.total++;
      false_alarm.hits += o.Warned("unexplained_structure");
    }
  }
  std::printf("earlier kinds: the right effect first %s; unexplained_structure where found %s\n",
              found.Text().c_str(), false_alarm.Text().c_str());
  EXPECT_TRUE(found.AtLeastFiveInSix()) << "earlier kinds: right on " << found.Text();
  EXPECT_LE(6 * false_alarm.hits, std::max(6, false_alarm.total))
      << "earlier kinds: unexplained_structure where the right effect was found, "
      << false_alarm.Text();
}

// The instrument: the independent simulator's noise-free record against the tool's own
// simulation (blmd-sim --input, the truth's effects declared, true J and B) of the same
// input, for every effect the tool's build knows (spring and gravity are skipped, with a
// note, where blmd-sim refuses them). The worst |difference| relative to the column's peak,
// i and w.
// Runs blmd-sim on `clean`'s input with the truth declared at `steps_per_sample` tool steps
// per sample; the worst |difference| of i and w relative to the column's peak (negative: the
// tool refused the config, *why says why).
std::pair<double, double> ToolDeviation(const Case& c, const Record& clean, const TempDir& dir,
                                        double steps_per_sample, std::string* why) {
  const std::string csv = dir.Write("in.csv", independent::Csv(clean));
  const std::string config =
      dir.Write("truth.json", FitConfig(c, TruthEffects(c.e), true, steps_per_sample));
  const std::string out = dir.File("tool.csv");
  const CommandResult run = blmd::testing::Run(Tool("blmd-sim") + " --config " + config +
                                               " --input " + csv + " --out " + out + " --quiet");
  if (run.exit_code != 0) {
    *why = run.err.substr(0, run.err.find('\n'));
    return {-1.0, -1.0};
  }
  // The tool's CSV: header, then rows; the columns by name.
  std::ifstream in(out);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && line[0] == '#') std::getline(in, line);
  std::vector<std::string> header;
  {
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) header.push_back(cell);
  }
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const std::size_t ci = column("i"), cw = column("w"), ct = column("t");
  EXPECT_LT(ci, header.size());
  EXPECT_LT(cw, header.size());
  EXPECT_LT(ct, header.size());
  if (ci >= header.size() || cw >= header.size() || ct >= header.size()) return {1.0, 1.0};
  double worst_i = 0, worst_w = 0, peak_i = 0, peak_w = 0;
  std::size_t row = 0;
  while (std::getline(in, line) && row < clean.t.size()) {
    std::vector<double> v;
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::atof(cell.c_str()));
    EXPECT_NEAR(v[ct], clean.t[row], 1e-9 * (1 + clean.t[row]));
    worst_i = std::max(worst_i, std::abs(v[ci] - clean.i[row]));
    if (std::getenv("STUDY_DEBUG") && std::abs(v[cw] - clean.w[row]) > worst_w)
      std::printf("  row %zu t %.6g u %g w_ind %.6g w_tool %.6g i_ind %.6g theta %.6g\n", row,
                  clean.t[row], clean.u[row], clean.w[row], v[cw], clean.i[row], clean.theta[row]);
    worst_w = std::max(worst_w, std::abs(v[cw] - clean.w[row]));
    peak_i = std::max(peak_i, std::abs(clean.i[row]));
    peak_w = std::max(peak_w, std::abs(clean.w[row]));
    ++row;
  }
  EXPECT_EQ(row, clean.t.size());
  return {worst_i / peak_i, worst_w / peak_w};
}

// The instrument: the independent simulator's noise-free record against the tool's own
// simulation (blmd-sim --input, the truth's effects declared, true J and B) of the same
// input, for every effect the tool's build knows (spring and gravity are skipped, with a
// note, where blmd-sim refuses them; the disturbance has no name). The worst |difference|
// relative to the column's peak, of i and w, at the studies' tool step (1/4 sample, printed)
// and at 1/256 sample (STUDY_TOOL_FINE; asserted within 0.5 %: the equations agree, what is
// left is the tool's step). Measured on main (2026-11-27): single effects agree to 4e-4 of
// the peak or better at 1/4 sample; Coulomb friction with cogging differs by up to 1.5 % of
// the peak speed at 1/4 sample and still 1.0 % at 1/32 (a shaft crawling through a detent
// at a reversal: the tool's stick and breakaway instants are located to within its step),
// 0.1 % at 1/256. The independent simulator itself changes by < 1e-4 of the peak from 64
// to 512 substeps (STUDY_SUBSTEPS).
TEST(IndependentServo, AgreesWithTheToolsSimulation) {
  TempDir dir;
  struct Check {
    std::string kind;
    int k;
  };
  const std::vector<Check> checks = {
      {"earlier", 0},         {"earlier", 1},         {"earlier", 2},
      {"earlier", 3},         {"earlier", 4},         {"earlier", 5},
      {"spring", 0},          {"gravity_turning", 0}, {"gravity_swinging", 0},
      {"coulomb_cogging", 0}, {"coulomb_cogging", 2}, {"coulomb_cogging", 4}};
  for (const auto& check : checks) {
    const Case c = MakeCase(check.kind, check.k);
    const Record clean = Simulate(c.m, c.e, c.period);
    std::string why;
    const auto coarse = ToolDeviation(c, clean, dir, 4.0, &why);
    if (coarse.first < 0) {
      std::printf("%-16s %d (%s): the tool refuses it: %s\n", check.kind.c_str(), check.k,
                  c.truth.c_str(), why.c_str());
      EXPECT_TRUE(c.e.Ks > 0 || c.e.Tg > 0) << why;  // only spring or gravity may be refused
      continue;
    }
    const auto fine = ToolDeviation(c, clean, dir, Count("STUDY_TOOL_FINE", 256), &why);
    std::printf(
        "%-16s %d (%-24s %-30s): worst deviation of the peak, tool dt 1/4 sample: i %.2e w "
        "%.2e; 1/256 sample: i %.2e w %.2e\n",
        check.kind.c_str(), check.k, (c.truth + ")").c_str(), c.size.c_str(), coarse.first,
        coarse.second, fine.first, fine.second);
    EXPECT_LT(fine.first, 0.005) << c.kind << " " << c.k;
    EXPECT_LT(fine.second, 0.005) << c.kind << " " << c.k;
  }
}

}  // namespace
}  // namespace blmd::testing
