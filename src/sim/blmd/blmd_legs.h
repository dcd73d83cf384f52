// Private helpers of the blmd model shared by its reference and fast paths
// (src/sim/blmd/blmd_drive.cc, src/sim/blmd/blmd_drive_fast.cc; docs/model-blmd.md §2, §5).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "blmd/sim/effects.h"
#include "blmd/sim/experiment.h"
#include "blmd/sim/parameters.h"

namespace blmd::internal {

// The output columns of a blmd run (blmd_drive.h): t is added by the sampler.
inline std::vector<std::string> BlmdOutputNames(bool diagnostics) {
  std::vector<std::string> names = {"u", "i", "ib", "ic", "w", "theta"};
  if (diagnostics) {
    for (const char* extra : {"va", "vb", "vc", "Te", "vsg"}) names.emplace_back(extra);
  }
  return names;
}

// The drive's parameters as a run reads them (docs/model-blmd.md §2), in their units.
struct BlmdParameters {
  double Ud, Rs, Ls, Ke, p, Kc, Kf, Kp, Ki, Tz, Tp, Vtri, Tpwm, delta, J, B;

  static BlmdParameters From(const ParameterSet& values) {
    BlmdParameters c;
    c.Ud = values.Get("Ud"), c.Rs = values.Get("Rs"), c.Ls = values.Get("Ls");
    c.Ke = values.Get("Ke"), c.p = values.Get("p"), c.Kc = values.Get("Kc");
    c.Kf = values.Get("Kf"), c.Kp = values.Get("Kp"), c.Ki = values.Get("Ki");
    c.Tz = values.Get("Tz"), c.Tp = values.Get("Tp"), c.Vtri = values.Get("Vtri");
    c.Tpwm = values.Get("Tpwm"), c.delta = values.Get("delta"), c.J = values.Get("J");
    c.B = values.Get("B");
    return c;
  }
};

// A run's constants of the fast step (backward-Euler gains, carrier), as the scalar fast
// path (blmd_drive_fast.cc) and the batched kernel (blmd_batch_kernel.inc) both use them:
// one computation, so the two round alike and the lanes equal Simulate() bit for bit.
struct BlmdStepConstants {
  double Ud, Ke, p, Kc, Kf, Kp, Vtri, delta;  // as the parameters (V, V·s/rad, -, ...)
  double current_gain;             // 1 / (1 + dt Rs/Ls): i+ = (i + dt/Ls (v - e)) * current_gain
  double speed_gain;               // 1 / (1 + dt B/J)
  double lag_norm;                 // 1 / (1 + Tp/dt), the lead-lag's
  double Tp_dt, lead_gain, Tz_dt;  // Tp/dt, 1 + Tz/dt, Tz/dt
  double Ki_dt;                    // V/V, Ki dt
  double dt_Ls, Ls_dt, dt_J;
  bool lead_lag;               // Tz or Tp != 0
  long steps_per_half_period;  // Tpwm / (2 dt), whole (Validate)
  double carrier_slope;        // V per step
  ShaftEffects shaft;
  DriveEffects drive;

  static BlmdStepConstants From(const ParameterSet& values, const std::vector<std::string>& effects,
                                const SimulationSettings& settings) {
    const double dt = settings.dt;
    const double Rs = values.Get("Rs"), Ls = values.Get("Ls"), Ki = values.Get("Ki"),
                 Tz = values.Get("Tz"), Tp = values.Get("Tp"), J = values.Get("J"),
                 B = values.Get("B");
    BlmdStepConstants k;
    k.Ud = values.Get("Ud");
    k.Ke = values.Get("Ke");
    k.p = values.Get("p");
    k.Kc = values.Get("Kc");
    k.Kf = values.Get("Kf");
    k.Kp = values.Get("Kp");
    k.Vtri = values.Get("Vtri");
    k.delta = values.Get("delta");
    k.current_gain = 1.0 / (1.0 + dt * Rs / Ls);
    k.speed_gain = 1.0 / (1.0 + dt * B / J);
    k.lag_norm = 1.0 / (1.0 + Tp / dt);
    k.Tp_dt = Tp / dt;
    k.lead_gain = 1.0 + Tz / dt;
    k.Tz_dt = Tz / dt;
    k.Ki_dt = Ki * dt;
    k.dt_Ls = dt / Ls;
    k.Ls_dt = Ls / dt;
    k.dt_J = dt / J;
    k.lead_lag = Tz != 0.0 || Tp != 0.0;
    k.steps_per_half_period = std::lround(0.5 * values.Get("Tpwm") / dt);
    k.carrier_slope = 2.0 * k.Vtri / static_cast<double>(k.steps_per_half_period);
    k.shaft = ShaftEffects::From(values, effects, settings.friction_smoothing_w);
    k.drive = DriveEffects::From(values, effects);
    return k;
  }
};

// Time within [a, b] during which a switch commanded on since t_edge conducts, given the
// turn-on delay delta.
inline double ConductingTime(double a, double b, double t_edge, double delta) {
  return std::max(0.0, b - std::max(a, t_edge + delta));
}

// The inverter legs over one step (paper eqs. 12-14) with the diodes decided at the step's
// end, as backward Euler decides every other sub-system. Leg j's step-average voltage is
//   v_jg = switched_j + off_j * v_off_j,
// switched_j = Ud * (upper switch conduction time) / dt, off_j = (both-off time) / dt, and
// over its both-off time the leg is at v_off_j in [0, Ud]:
//   v_off_j = 0   (lower diode) if i_j(t_H) > 0,
//   v_off_j = Ud  (upper diode) if i_j(t_H) < 0,
//   0 <= v_off_j <= Ud, i_j(t_H) = 0 (open phase: both diodes block, the terminal floats).
// With backward Euler i_j(t_H) = g dt/Ls (v_jg - v_sg - hold_j), hold_j = e_j - Ls i_j(t_L)/dt,
// v_sg = (v_1g + v_2g + v_3g)/3: a linear complementarity problem in at most three
// unknowns, solved exactly by trying the modes (first the one from the sign of i_j(t_L),
// which is the answer whenever no current reaches zero). Its currents are unique and
// Lipschitz in the state: no chatter at zero current, no sensitivity beyond the physics'.
// Writes the leg voltages and which phases end the step open (their current is exactly 0).
class LegSolver {
 public:
  static constexpr int kLower = 0, kUpper = 1, kOpen = 2;

  static void Solve(const double switched[3], const double off[3], const double hold[3],
                    const double current[3], double Ud, double v[3], bool open[3]) {
    int mode[3];
    int free_legs[3], num_free = 0;
    for (int j = 0; j < 3; ++j) {
      mode[j] = current[j] > 0.0 ? kLower : (current[j] < 0.0 ? kUpper : kOpen);
      if (off[j] > 0.0) free_legs[num_free++] = j;
    }
    if (Try(mode, switched, off, hold, Ud, v, open)) return;
    int combos = 1;
    for (int k = 0; k < num_free; ++k) combos *= 3;
    for (int code = 0; code < combos; ++code) {
      int rest = code;
      for (int k = 0; k < num_free; ++k) {
        mode[free_legs[k]] = rest % 3;
        rest /= 3;
      }
      if (Try(mode, switched, off, hold, Ud, v, open)) return;
    }
    // Not reached for a consistent state (the problem always has a solution); should
    // rounding defeat every mode, the leg keeps the diode of its current's sign at t_L.
    for (int j = 0; j < 3; ++j) {
      v[j] = switched[j] + (off[j] > 0.0 && current[j] < 0.0 ? Ud * off[j] : 0.0);
      open[j] = false;
    }
  }

 private:
  static bool Try(const int mode[3], const double switched[3], const double off[3],
                  const double hold[3], double Ud, double v[3], bool open[3]) {
    const double tolerance = 1e-9 * Ud;  // V
    double fixed_sum = 0.0, hold_sum = 0.0;
    int num_open = 0;
    for (int j = 0; j < 3; ++j) {
      open[j] = off[j] > 0.0 && mode[j] == kOpen;
      if (open[j]) {
        ++num_open;
        hold_sum += hold[j];
      } else {
        v[j] = switched[j] + (off[j] > 0.0 && mode[j] == kUpper ? Ud * off[j] : 0.0);
        fixed_sum += v[j];
      }
    }
    double neutral = 0.0;
    if (num_open < 3) {
      neutral = (fixed_sum + hold_sum) / static_cast<double>(3 - num_open);
    } else {
      // Every phase open: all currents stay zero and the neutral floats; take the middle of
      // the range that keeps every terminal within [0, Ud].
      double low = -1e300, high = 1e300;
      for (int j = 0; j < 3; ++j) {
        low = std::max(low, switched[j] - hold[j]);
        high = std::min(high, switched[j] + Ud * off[j] - hold[j]);
      }
      if (low > high + tolerance) return false;
      neutral = 0.5 * (low + high);
    }
    for (int j = 0; j < 3; ++j) {
      if (open[j]) {
        v[j] = hold[j] + neutral;
        const double v_off = (v[j] - switched[j]) / off[j];
        if (v_off < -tolerance || v_off > Ud + tolerance) return false;
      } else if (off[j] > 0.0) {
        const double drive = v[j] - neutral - hold[j];  // sign of i_j(t_H)
        if (mode[j] == kLower && drive < -tolerance) return false;
        if (mode[j] == kUpper && drive > tolerance) return false;
      }
    }
    return true;
  }
};

}  // namespace blmd::internal
