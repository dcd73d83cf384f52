// The effects vocabulary (docs/effects.md): extra physics a model can carry.
// One implementation, shared by every model. All shaft torques are in N·m and enter the
// mechanical equation as T_effects, i.e. they are *subtracted* from the drive torque:
//
//   J dw/dt = T_drive - B w - T_effects
//   T_effects = Tc sign(w)                                (coulomb_friction; sticks at rest)
//             + Ts exp(-(w/ws)^2) sign(w)                 (stribeck; adds to breakaway)
//             + TL                                        (load_torque, signed)
//             + Cd w |w|                                  (quadratic_drag)
//             + dB |w|                                    (asymmetric_viscous)
//             + Tcog sin(periods theta + phase)           (cogging)
//             + K (theta - theta0)                        (spring: the torque -K (theta - theta0))
//             + Tg sin(theta + gravity_phase)             (gravity: the torque -Tg sin(...))
//
// two_mass is no torque of the state but a second body: the shaft of inertia J splits into
// the motor, Jm = J/(1+r), and a load, Jl = J r/(1+r), joined by a stiffness K = Jl (2 pi fa)^2
// with damping c = 2 zeta Jl (2 pi fa), and B into the motor's (1-s) B and the load's s B; the
// torques above act on the motor, whose speed and angle are the ones measured (rigid_load,
// docs/effects.md).
//
// spring and gravity act on the shaft as -K (theta - theta0) and -Tg sin(theta + phase):
// restoring torques, so their T_effects (subtracted) are the opposite signs above. A spring
// pulls the shaft back to theta0; gravity (an unbalanced arm, a pendulum) to the angle where
// theta + phase = 0 (its stable equilibrium). Both act at rest too; static friction can hold
// them like a load.
//
// asymmetric_viscous makes the viscous damping depend on the direction: with B w it gives
// B+ = B + dB turning forwards (w > 0) and B- = B - dB backwards (physically valid while
// |dB| < B). Like drag it is explicit in the step (both vanish at rest, so sticking and the
// stop rule are unchanged).
//
// Electrical effects: dead_time (dc_servo) u_eff = u - Vdt sign(i);
// current_offset: measured i = true i + i0 (output only).
//
// Sticking (Karnopp): at w = 0 the shaft stays at rest while |T_drive - TL - T_cog| does not
// exceed the breakaway torque Tc + Ts; otherwise it breaks away with friction opposing the
// net torque. A step in which w would change sign stops the shaft at the interpolated instant,
// so friction never reverses the motion it opposes; for the rest of that step the same rule
// holds at rest (StopInStep: dc_servo and rigid_load; the BLMD drive ends the step at rest).
// SimulationSettings::friction_smoothing_w replaces sign(w) by tanh(w / eps) (no sticking) for
// optimisers that need a smooth cost.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "blmd/sim/parameters.h"
#include "blmd/sim/two_mass.h"

namespace blmd {

// A figure computed from the parameters (model's and effect's), in `unit`.
struct DerivedInfo {
  std::string name;
  std::string unit;
  std::string meaning;
  std::function<double(const ParameterSet&)> value;
};

struct EffectInfo {
  std::string name;
  std::vector<ParamInfo> parameters;
  std::string equation;             // as in docs/effects.md
  std::vector<std::string> models;  // models that support it
  // Its torque depends on the shaft angle (cogging, spring, gravity): discovery fits it at the
  // measured angle (docs/discovery.md, "Cogging: the measured angle").
  bool position_dependent = false;
  // What it does to a shaft at rest, for the breakaway a designed input must exceed
  // (TorqueAtRest, docs/design.md §7): friction that holds the shaft (the largest such
  // amplitude counts), a torque that loads it whatever the angle it rests at (added at its
  // amplitude), or neither. A spring's torque at rest depends on where the shaft rests
  // against its rest angle, which no parameter says: neither.
  enum class AtRest { kNothing, kHoldsByFriction, kLoads };
  AtRest at_rest = AtRest::kNothing;
  std::string at_rest_amplitude{};  // the parameter whose |value| is that torque, N·m
  // Figures a user asks for that are functions of the parameters (two_mass: the resonance,
  // the two inertias, the stiffness): reported with their intervals by the delta method
  // (ident/uncertainty/derived_quantities.h).
  std::vector<DerivedInfo> derived{};
  // It adds states the record's initial conditions do not give (two_mass: the load's speed and
  // the shaft's twist): a part of the record cut from the middle starts them wrong, so the
  // adequacy check's comparison of the record's parts leaves its parameters out.
  bool hidden_states = false;
  // Columns it adds to the model's outputs (two_mass: the load's speed and angle, what a
  // second, load-side encoder measures), written by the simulation and observable in a fit.
  std::vector<std::string> outputs{};
};

// Every effect, sorted by name. The one place that knows them all.
const std::vector<EffectInfo>& EffectRegistry();
// Throws InputError listing the valid names when `name` is unknown.
const EffectInfo& FindEffect(const std::string& name);
bool IsEffectParameter(const std::string& parameter, std::string* effect_name = nullptr);
// The torque (N·m) that holds a shaft at rest under the `enabled` effects at `values`: the
// largest amplitude of the effects that hold it by friction plus the amplitude of each that
// loads it (EffectInfo::at_rest). `friction`, when given, says whether any enabled effect
// holds it by friction.
double TorqueAtRest(const ParameterSet& values, const std::vector<std::string>& enabled,
                    bool* friction = nullptr);
// The names of the effects that hold a shaft at rest by friction, sorted.
std::vector<std::string> FrictionAtRestEffects();
// True when `parameter` (a flat name) is an effect's angle that wraps (ParamInfo::periodic).
bool IsPeriodicParameter(const std::string& parameter);
// True when `parameter` (a flat name) is an effect's share in [0, 1] (ParamInfo::share).
bool IsShareParameter(const std::string& parameter);

// Hot-loop view of the enabled shaft effects, unpacked once per simulation.
struct ShaftEffects {
  double Tc = 0.0;             // Coulomb friction, N·m
  double Ts = 0.0;             // Stribeck extra breakaway torque, N·m
  double ws = 1.0;             // Stribeck velocity, rad/s
  double TL = 0.0;             // constant load torque, N·m (opposes positive motion)
  double Cd = 0.0;             // quadratic drag, N·m·s²/rad²
  double dB = 0.0;             // direction-dependent viscous damping, N·m·s/rad (B± = B ± dB)
  double Tcog = 0.0;           // cogging amplitude, N·m
  double cog_periods = 0.0;    // cogging periods per shaft revolution
  double cog_phase = 0.0;      // cogging phase, rad
  double K = 0.0;              // spring stiffness, N·m/rad
  double theta0 = 0.0;         // spring rest angle, rad
  double Tg = 0.0;             // gravity torque amplitude (arm's m g l), N·m
  double gravity_phase = 0.0;  // gravity phase, rad (stable equilibrium at theta = -phase)
  double smoothing_w = 0.0;    // rad/s; > 0: tanh(w/eps) friction without sticking
  // two_mass: a flexible coupling to the load (rigid_load's four-state step); 0: rigid.
  double inertia_ratio = 0.0;        // Jl/Jm
  double anti_resonance_hz = 0.0;    // sqrt(K/Jl)/(2 pi), Hz
  double shaft_damping_ratio = 0.0;  // c/(2 sqrt(K Jl))
  double load_damping_share = 0.0;   // s: the load's viscous damping Bl = s B, the motor's (1-s) B

  bool has_friction() const { return Tc > 0.0 || Ts > 0.0; }
  bool two_mass() const { return inertia_ratio > 0.0 && anti_resonance_hz > 0.0; }
  // The two sides of the coupling for the totals J and B.
  TwoMassSides Sides(double J, double B) const {
    return TwoMassSides::Of(J, B, inertia_ratio, anti_resonance_hz, shaft_damping_ratio,
                            load_damping_share);
  }

  static ShaftEffects From(const ParameterSet& values, const std::vector<std::string>& enabled,
                           double smoothing_w);

  // True when a torque depends on the shaft angle (cogging, spring, gravity).
  bool position_dependent() const { return Tcog != 0.0 || K != 0.0 || Tg != 0.0; }

  // Torques other than friction (load, cogging, spring, gravity), in the T_effects sense.
  double NonFrictionTorque(double theta) const {
    double torque = TL;
    if (Tcog != 0.0) torque += Tcog * std::sin(cog_periods * theta + cog_phase);
    if (K != 0.0) torque += K * (theta - theta0);
    if (Tg != 0.0) torque += Tg * std::sin(theta + gravity_phase);
    return torque;
  }
  // Speed-dependent torques besides B w: quadratic drag and the asymmetric viscous part.
  double DragTorque(double w) const { return (Cd * w + dB) * std::abs(w); }
  // Kinetic friction magnitude at speed w (Coulomb + Stribeck), N·m.
  double FrictionMagnitude(double w) const {
    double magnitude = Tc;
    if (Ts != 0.0) magnitude += Ts * std::exp(-(w / ws) * (w / ws));
    return magnitude;
  }

  // Friction torque (T_effects sense) to hold over one step starting at speed w, given the
  // net torque the shaft would feel without friction (T_drive - non-friction effects).
  // Sets *stuck when the shaft is at rest and cannot break away.
  double StepFriction(double w, double net_torque_without_friction, bool* stuck) const {
    *stuck = false;
    if (!has_friction()) return 0.0;
    if (smoothing_w > 0.0) return FrictionMagnitude(w) * std::tanh(w / smoothing_w);
    if (w > 0.0) return FrictionMagnitude(w);
    if (w < 0.0) return -FrictionMagnitude(w);
    const double breakaway = FrictionMagnitude(0.0);
    if (std::abs(net_torque_without_friction) <= breakaway) {
      *stuck = true;
      return net_torque_without_friction;  // static friction balances exactly
    }
    return net_torque_without_friction > 0.0 ? breakaway : -breakaway;
  }
  // True when a step from w_old to w_new under friction must end at rest.
  bool StopsWithin(double w_old, double w_new) const {
    return has_friction() && smoothing_w <= 0.0 &&
           ((w_old > 0.0 && w_new < 0.0) || (w_old < 0.0 && w_new > 0.0));
  }
  // A step of dt from (w_old, theta_old) that ended at *w, *theta: when friction stopped the
  // shaft inside it, the shaft stops at the interpolated instant (theta advanced by the mean
  // speed up to it) and for the rest of the step sticks, unless `net`, the torque it feels at
  // rest without friction (drive minus the positional effects), exceeds the breakaway torque:
  // then it breaks away at once in the direction of `net` and moves for the remainder tau
  // under the excess F, J dw/dt = F - B w from rest (J in kg·m², B in N·m·s/rad). Returns
  // true when the shaft stopped. Waiting for the next step to break away would make the
  // reversal's instant jump by a step whenever the stop crosses a step boundary, and the
  // cost with it: a staircase in the parameters (docs/model-rigid-load.md, "Sticking").
  bool StopInStep(double w_old, double theta_old, double dt, double J, double B, double net,
                  double* w, double* theta) const {
    if (!StopsWithin(w_old, *w)) return false;
    const double fraction = w_old / (w_old - *w);
    *theta = theta_old + 0.5 * w_old * fraction * dt;
    *w = 0.0;
    const double breakaway = FrictionMagnitude(0.0);
    if (!(std::abs(net) > breakaway)) return true;
    // w = (F/J) tau phi1(-a tau), theta = (F/J) tau^2 phi2(-a tau), a = B/J,
    // phi1(x) = (e^x - 1)/x, phi2(x) = (e^x - 1 - x)/x^2 (their series near 0).
    const double excess = net - std::copysign(breakaway, net);
    const double tau = (1.0 - fraction) * dt;
    const double x = -B / J * tau;
    double phi1, phi2;
    if (std::abs(x) < 1e-4) {
      phi1 = 1.0 + x * (0.5 + x / 6.0);
      phi2 = 0.5 + x * (1.0 / 6.0 + x / 24.0);
    } else {
      const double e = std::expm1(x);
      phi1 = e / x;
      phi2 = (e - x) / (x * x);
    }
    *w = excess / J * tau * phi1;
    *theta += excess / J * tau * tau * phi2;
    return true;
  }
};

// The angle the position-dependent effects see (SimulationSettings::effect_angle): the
// simulated one, or a sampled angle interpolated linearly in time (held beyond its ends).
// Times are visited in increasing order, so the lookup walks a cursor: O(1) per step.
class EffectAngle {
 public:
  EffectAngle(const std::vector<double>* times, const std::vector<double>* angle)
      : times_(angle ? times : nullptr), angle_(angle) {}
  double At(double t, double simulated_theta) {
    if (!angle_) return simulated_theta;
    const std::vector<double>& ts = *times_;
    const std::vector<double>& a = *angle_;
    if (t <= ts.front()) return a.front();
    if (t >= ts.back()) return a.back();
    while (cursor_ + 1 < ts.size() && ts[cursor_ + 1] < t) ++cursor_;
    const double f = (t - ts[cursor_]) / (ts[cursor_ + 1] - ts[cursor_]);
    return a[cursor_] + f * (a[cursor_ + 1] - a[cursor_]);
  }

 private:
  const std::vector<double>* times_;
  const std::vector<double>* angle_;
  std::size_t cursor_ = 0;
};

// Electrical effects, unpacked once per simulation.
struct DriveEffects {
  double Vdt = 0.0;  // dead-time voltage loss, V (dc_servo): u_eff = u - Vdt sign(i)
  double i0 = 0.0;   // current-sensor offset, A: measured i = i + i0

  static DriveEffects From(const ParameterSet& values, const std::vector<std::string>& enabled);
};

}  // namespace blmd
