#include "blmd/sim/effects.h"

#include <algorithm>
#include <cmath>

#include "blmd/constants.h"
#include "blmd/error.h"

namespace blmd {
namespace {

// How a parameter's values are limited: any sign, 0 or more, or more than 0 (then searched
// on a log scale when free).
enum class Sign { kAny, kNonNegative, kPositive };

ParamInfo P(std::string name, std::string unit, std::string meaning, Sign sign, double lower,
            double upper, std::string key = "") {
  ParamInfo info;
  info.key = std::move(key);
  info.name = std::move(name);
  info.unit = std::move(unit);
  info.meaning = std::move(meaning);
  info.positive = sign == Sign::kPositive;
  info.non_negative = sign == Sign::kNonNegative;
  info.default_lower = lower;
  info.default_upper = upper;
  return info;
}

// A phase, rad: an angle that wraps (ParamInfo::periodic).
ParamInfo Phase(std::string name, std::string meaning, std::string key = "") {
  ParamInfo info =
      P(std::move(name), "rad", std::move(meaning), Sign::kAny, -kPi, kPi, std::move(key));
  info.periodic = true;
  return info;
}

// A share in [0, 1] (ParamInfo::share).
ParamInfo Share(std::string name, std::string meaning) {
  ParamInfo info = P(std::move(name), "1", std::move(meaning), Sign::kNonNegative, 0.0, 1.0);
  info.share = true;
  return info;
}

std::vector<EffectInfo> MakeRegistry() {
  const std::vector<std::string> all = {"blmd", "dc_servo", "rigid_load"};
  std::vector<EffectInfo> effects = {
      // dc_servo is not listed: its fast path (src/sim/dc_servo/dc_servo_fast.cc) skips DragTorque
      // when the shaft has no friction, drag or cogging, so dB alone would be ignored there.
      {"asymmetric_viscous",
       {P("dB", "N·m·s/rad", "direction-dependent viscous damping: B+ = B + dB, B- = B - dB",
          Sign::kAny, -1e5, 1e5)},
       "T = dB |w| (B+ = B + dB for w > 0, B- = B - dB for w < 0; valid while |dB| < B)",
       {"blmd", "rigid_load"}},
      {"cogging",
       {P("Tcog", "N·m", "cogging torque amplitude", Sign::kNonNegative, 0.0, 10.0),
        P("periods", "1/rev", "cogging periods per shaft revolution", Sign::kPositive, 1.0, 200.0),
        Phase("phase", "cogging phase")},
       "T = Tcog sin(periods theta + phase)",
       all,
       /*position_dependent=*/true,
       EffectInfo::AtRest::kLoads,
       "Tcog"},
      {"coulomb_friction",
       {P("Tc", "N·m", "Coulomb friction torque", Sign::kNonNegative, 0.0, 10.0)},
       "T = Tc sign(w), sticking at rest",
       all,
       /*position_dependent=*/false,
       EffectInfo::AtRest::kHoldsByFriction,
       "Tc"},
      {"current_offset",
       {P("i0", "A", "current sensor offset", Sign::kAny, -10.0, 10.0)},
       "i_measured = i + i0",
       {"blmd", "dc_servo"}},
      {"dead_time",
       {P("Vdt", "V", "drive voltage lost to inverter blanking", Sign::kNonNegative, 0.0, 50.0)},
       "u_eff = u - Vdt sign(i)",
       {"dc_servo"}},
      // The flat name of gravity's phase is gravity_phase: cogging owns `phase`. Inside the
      // gravity object of a config and in --effect it is `phase` (ParamInfo::key).
      {"gravity",
       {P("Tg", "N·m", "gravity torque amplitude (unbalanced arm or pendulum: m g l)",
          Sign::kNonNegative, 0.0, 100.0),
        Phase("gravity_phase", "gravity phase (stable equilibrium at theta = -phase)", "phase")},
       "T = -Tg sin(theta + phase) on the shaft (T_effects = Tg sin(theta + phase))",
       all,
       /*position_dependent=*/true,
       EffectInfo::AtRest::kLoads,
       "Tg"},
      {"load_torque",
       {P("TL", "N·m", "constant load torque opposing positive motion", Sign::kAny, -100.0, 100.0)},
       "T = TL",
       all,
       /*position_dependent=*/false,
       EffectInfo::AtRest::kLoads,
       "TL"},
      {"quadratic_drag",
       {P("Cd", "N·m·s²/rad²", "quadratic (fan, windage) drag coefficient", Sign::kNonNegative, 0.0,
          1.0)},
       "T = Cd w |w|",
       all},
      {"spring",
       {P("K", "N·m/rad", "torsional spring stiffness", Sign::kNonNegative, 0.0, 1e4),
        P("theta0", "rad", "spring rest angle", Sign::kAny, -1e4, 1e4)},
       "T = -K (theta - theta0) on the shaft (T_effects = K (theta - theta0))",
       all,
       /*position_dependent=*/true},
      {"stribeck",
       {P("Ts", "N·m", "extra breakaway friction at rest", Sign::kNonNegative, 0.0, 10.0),
        P("ws", "rad/s", "Stribeck velocity", Sign::kPositive, 1e-3, 1e3)},
       "T = Ts exp(-(w/ws)^2) sign(w)",
       all,
       /*position_dependent=*/false,
       EffectInfo::AtRest::kHoldsByFriction,
       "Ts"},
      // A flexible coupling between the motor and its load (docs/effects.md, "two_mass"): J and
      // B stay the totals a rigid fit gives (below the resonance the shaft is rigid), split
      // between the two sides; the measured speed and angle are the motor's. Simulated by
      // rigid_load (its exact four-state step), dc_servo (five states, the armature's
      // current the first) and blmd (the drive's torque on the motor's side, the shaft's exact
      // four-state step on the reference step loop).
      {"two_mass",
       {P("inertia_ratio", "1", "load inertia over motor inertia, Jl/Jm", Sign::kPositive, 1e-3,
          1e3),
        P("anti_resonance_hz", "Hz", "anti-resonance frequency sqrt(K/Jl)/(2 pi)", Sign::kPositive,
          0.1, 1e5),
        P("shaft_damping_ratio", "1",
          "the shaft's damping ratio at the anti-resonance, c/(2 sqrt(K Jl))", Sign::kNonNegative,
          0.0, 2.0),
        Share("load_damping_share",
              "the share s of B that acts on the load: Bl = s B, Bm = (1-s) B")},
       "Jm dwm/dt = T - Bm wm - K (thm - thl) - c (wm - wl), Jl dwl/dt = K (thm - thl) + c (wm - "
       "wl) - Bl wl; Jm = J/(1+r), Jl = J r/(1+r), K = Jl (2 pi fa)^2, c = 2 zeta Jl 2 pi fa, "
       "Bm = (1-s) B, Bl = s B",
       {"rigid_load", "dc_servo", "blmd"},
       /*position_dependent=*/false,
       EffectInfo::AtRest::kNothing,
       "",
       {{"resonance_hz", "Hz", "resonance f_r = f_a sqrt(1 + r), where the motor's speed peaks",
         [](const ParameterSet& p) {
           return p.Get("anti_resonance_hz") * std::sqrt(1.0 + p.Get("inertia_ratio"));
         }},
        // The anti-resonance under the name the report's readers look for beside
        // resonance_hz (docs/effects.md: the parameter anti_resonance_hz, the same interval).
        {"antiresonance_hz", "Hz",
         "anti-resonance f_a, where the motor's speed dips (= anti_resonance_hz)",
         [](const ParameterSet& p) { return p.Get("anti_resonance_hz"); }},
        {"motor_inertia", "kg·m²", "the motor side's inertia Jm = J/(1 + r)",
         [](const ParameterSet& p) { return p.Get("J") / (1.0 + p.Get("inertia_ratio")); }},
        {"load_inertia", "kg·m²", "the load side's inertia Jl = J r/(1 + r)",
         [](const ParameterSet& p) {
           const double r = p.Get("inertia_ratio");
           return p.Get("J") * r / (1.0 + r);
         }},
        {"shaft_stiffness", "N·m/rad", "the coupling's stiffness K = Jl (2 pi f_a)^2",
         [](const ParameterSet& p) {
           const double r = p.Get("inertia_ratio"), wa = 2.0 * kPi * p.Get("anti_resonance_hz");
           return p.Get("J") * r / (1.0 + r) * wa * wa;
         }}},
       /*hidden_states=*/true,
       /*outputs=*/{"w_load", "theta_load"}},
  };
  return effects;
}

}  // namespace

const std::vector<EffectInfo>& EffectRegistry() {
  static const std::vector<EffectInfo> registry = MakeRegistry();
  return registry;
}

const EffectInfo& FindEffect(const std::string& name) {
  for (const auto& effect : EffectRegistry()) {
    if (effect.name == name) return effect;
  }
  std::string valid;
  for (const auto& effect : EffectRegistry()) valid += (valid.empty() ? "" : ", ") + effect.name;
  throw InputError("unknown effect '" + InputError::Excerpt(name) + "' (valid: " + valid + ")");
}

bool IsPeriodicParameter(const std::string& parameter) {
  for (const auto& effect : EffectRegistry()) {
    for (const auto& info : effect.parameters) {
      if (info.name == parameter) return info.periodic;
    }
  }
  return false;
}

bool IsShareParameter(const std::string& parameter) {
  for (const auto& effect : EffectRegistry()) {
    for (const auto& info : effect.parameters) {
      if (info.name == parameter) return info.share;
    }
  }
  return false;
}

bool IsEffectParameter(const std::string& parameter, std::string* effect_name) {
  for (const auto& effect : EffectRegistry()) {
    for (const auto& info : effect.parameters) {
      if (info.name == parameter) {
        if (effect_name) *effect_name = effect.name;
        return true;
      }
    }
  }
  return false;
}

double TorqueAtRest(const ParameterSet& values, const std::vector<std::string>& enabled,
                    bool* friction) {
  double holding = 0.0, loads = 0.0;
  bool any_friction = false;
  for (const EffectInfo& effect : EffectRegistry()) {
    if (effect.at_rest == EffectInfo::AtRest::kNothing ||
        std::find(enabled.begin(), enabled.end(), effect.name) == enabled.end())
      continue;
    const double amplitude = std::abs(values.Get(effect.at_rest_amplitude));
    if (effect.at_rest == EffectInfo::AtRest::kHoldsByFriction) {
      any_friction = true;
      holding = std::max(holding, amplitude);
    } else {
      loads += amplitude;
    }
  }
  if (friction) *friction = any_friction;
  return holding + loads;
}

std::vector<std::string> FrictionAtRestEffects() {
  std::vector<std::string> names;
  for (const EffectInfo& effect : EffectRegistry()) {
    if (effect.at_rest == EffectInfo::AtRest::kHoldsByFriction) names.push_back(effect.name);
  }
  return names;
}

ShaftEffects ShaftEffects::From(const ParameterSet& values, const std::vector<std::string>& enabled,
                                double smoothing_w) {
  ShaftEffects shaft;
  shaft.smoothing_w = smoothing_w;
  auto on = [&](const char* name) {
    return std::find(enabled.begin(), enabled.end(), name) != enabled.end();
  };
  if (on("coulomb_friction")) shaft.Tc = values.Get("Tc");
  if (on("stribeck")) {
    shaft.Ts = values.Get("Ts");
    shaft.ws = values.Get("ws");
  }
  if (on("load_torque")) shaft.TL = values.Get("TL");
  if (on("quadratic_drag")) shaft.Cd = values.Get("Cd");
  if (on("asymmetric_viscous")) shaft.dB = values.Get("dB");
  if (on("cogging")) {
    shaft.Tcog = values.Get("Tcog");
    shaft.cog_periods = values.Get("periods");
    shaft.cog_phase = values.Get("phase");
  }
  if (on("spring")) {
    shaft.K = values.Get("K");
    shaft.theta0 = values.Get("theta0");
  }
  if (on("gravity")) {
    shaft.Tg = values.Get("Tg");
    shaft.gravity_phase = values.Get("gravity_phase");
  }
  if (on("two_mass")) {
    shaft.inertia_ratio = values.Get("inertia_ratio");
    shaft.anti_resonance_hz = values.Get("anti_resonance_hz");
    shaft.shaft_damping_ratio = values.Get("shaft_damping_ratio");
    shaft.load_damping_share = values.Get("load_damping_share");
  }
  return shaft;
}

DriveEffects DriveEffects::From(const ParameterSet& values,
                                const std::vector<std::string>& enabled) {
  DriveEffects drive;
  auto on = [&](const char* name) {
    return std::find(enabled.begin(), enabled.end(), name) != enabled.end();
  };
  if (on("dead_time")) drive.Vdt = values.Get("Vdt");
  if (on("current_offset")) drive.i0 = values.Get("i0");
  return drive;
}

}  // namespace blmd
