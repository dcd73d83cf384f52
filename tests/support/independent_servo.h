// An independent DC-servo simulator for the studies (tests/studies/adequacy_study_test.cc):
// written from the equations alone, sharing no code with src/ (no ShaftEffects, no model, no
// integrator, no random numbers of the library), so that a trace it makes tests the tool's
// model instead of reproducing it.
//
//   L di/dt = u - R i - K w - Vdt sign(i)                  (dead time: inverter blanking)
//   J dw/dt = K i - B w - T_extra(theta, w, t)             (T_extra opposes: subtracted)
//   dtheta/dt = w
//   T_extra = Tc sign(w) + TL + Cd w|w| + Tcog sin(m theta + phi_cog) + Ks (theta - theta0)
//           + Tg sin(theta + phi_g) + Td sin(2 pi f t + psi)
//
// so the spring's physical torque is -Ks (theta - theta0) (restoring) and gravity's is
// -Tg sin(theta + phi_g), as docs/effects.md and the interface's spring and gravity.
//
// Integration: classical fourth-order Runge-Kutta, `substeps` (64) equal steps per sample,
// the input u[k] held on [t_k, t_{k+1}) (zero-order hold, as the tool replays a trace).
// Discontinuities are handled with stick logic and event location, not smoothing:
// - Coulomb friction (Tc > 0): while moving, the friction's sign is held over a step; a step
//   in which w would change sign is cut where w crosses 0 (linear interpolation of the step's
//   end points, then the step redone to that instant), w is set to exactly 0 and the shaft
//   sticks. At rest (w == 0) it stays while |K i - T_other| <= Tc (T_other: every other
//   extra torque at w = 0, theta, t; checked at the start of every substep), so i still
//   evolves, theta and w are frozen; otherwise it breaks away with friction Tc opposing the
//   net torque. (The tool uses the same Karnopp rule at its own dt: the difference is that
//   this one locates the stop inside a 1/64-sample step and runs RK4 between events.)
// - Dead time (Vdt > 0): the same for the current: a step in which i would change sign is cut
//   at i = 0; at i == 0 the current stays 0 while |u - K w| <= Vdt (the blanking voltage
//   holds it: Filippov's sliding solution) and leaves with sign(u - K w) otherwise. The tool
//   uses sign(0) = 0; on a square wave the current crosses zero quickly and the two agree.
// Everything else is smooth and integrated to fourth order.
//
// Noise (AddNoise): white Gaussian, sigma = `fraction` (1 %) of each noisy column's RMS over
// the record (not its peak: a square wave's current is spiky, its RMS well below its peak),
// from std::mt19937_64 and the Box-Muller transform (portable: the same numbers on every
// standard library), on i and w; theta is left as simulated (an encoder's angle is precise
// to far below 1 %; the studies observe i and w only, and discovery uses theta only as the
// angle of cogging, where the measured theta is taken as it is).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace independent {

struct Servo {
  double R = 1.0, L = 1e-3, K = 0.05, J = 1e-5,
         B = 1e-5;  // ohm, H, N·m/A = V·s/rad, kg·m², N·m·s/rad
};

// Every extra torque (N·m, opposing: subtracted from K i) and the dead time; zero = absent.
struct Extras {
  double Tc = 0.0;                                        // Coulomb friction Tc sign(w), sticking
  double TL = 0.0;                                        // constant load (signed)
  double Cd = 0.0;                                        // drag Cd w|w|
  double Tcog = 0.0, cog_periods = 0.0, cog_phase = 0.0;  // Tcog sin(m theta + phase)
  double Ks = 0.0, theta0 = 0.0;                          // spring Ks (theta - theta0)
  double Tg = 0.0, gravity_phase = 0.0;                   // gravity Tg sin(theta + phase)
  double Td = 0.0, disturbance_hz = 0.0, disturbance_phase = 0.0;  // Td sin(2 pi f t + psi)
  double Vdt = 0.0;                                                // voltage loss Vdt sign(i), V
};

struct Record {
  std::vector<double> t, u, i, w, theta;
};

namespace detail {

struct State {
  double i = 0.0, w = 0.0, theta = 0.0;
};

inline double Sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

// Every extra torque but Coulomb friction.
inline double OtherTorque(const Extras& e, const State& x, double t) {
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  double T = e.TL + e.Cd * x.w * std::abs(x.w);
  if (e.Tcog != 0.0) T += e.Tcog * std::sin(e.cog_periods * x.theta + e.cog_phase);
  if (e.Ks != 0.0) T += e.Ks * (x.theta - e.theta0);
  if (e.Tg != 0.0) T += e.Tg * std::sin(x.theta + e.gravity_phase);
  if (e.Td != 0.0) T += e.Td * std::sin(kTwoPi * e.disturbance_hz * t + e.disturbance_phase);
  return T;
}

// Modes: friction sign sw (0 = stuck; only used when Tc > 0), dead-time sign si (0 = current
// held at zero; only used when Vdt > 0).
inline State Derivative(const Servo& m, const Extras& e, const State& x, double t, double u,
                        double sw, double si) {
  State d;
  if (e.Vdt > 0.0 && si == 0.0) {
    d.i = 0.0;
  } else {
    d.i = (u - (e.Vdt > 0.0 ? e.Vdt * si : 0.0) - m.R * x.i - m.K * x.w) / m.L;
  }
  if (e.Tc > 0.0 && sw == 0.0) {
    d.w = 0.0;
    d.theta = 0.0;
  } else {
    const double friction = e.Tc > 0.0 ? e.Tc * sw : 0.0;
    d.w = (m.K * x.i - m.B * x.w - OtherTorque(e, x, t) - friction) / m.J;
    d.theta = x.w;
  }
  return d;
}

inline State Axpy(const State& x, double h, const State& d) {
  return {x.i + h * d.i, x.w + h * d.w, x.theta + h * d.theta};
}

inline State Rk4(const Servo& m, const Extras& e, const State& x, double t, double h, double u,
                 double sw, double si) {
  const State k1 = Derivative(m, e, x, t, u, sw, si);
  const State k2 = Derivative(m, e, Axpy(x, 0.5 * h, k1), t + 0.5 * h, u, sw, si);
  const State k3 = Derivative(m, e, Axpy(x, 0.5 * h, k2), t + 0.5 * h, u, sw, si);
  const State k4 = Derivative(m, e, Axpy(x, h, k3), t + h, u, sw, si);
  return {x.i + h / 6.0 * (k1.i + 2.0 * k2.i + 2.0 * k3.i + k4.i),
          x.w + h / 6.0 * (k1.w + 2.0 * k2.w + 2.0 * k3.w + k4.w),
          x.theta + h / 6.0 * (k1.theta + 2.0 * k2.theta + 2.0 * k3.theta + k4.theta)};
}

// The modes at the start of a step: a stuck shaft breaks away when the net torque exceeds
// Tc; a held current leaves zero when the drive voltage exceeds Vdt.
inline void UpdateModes(const Servo& m, const Extras& e, const State& x, double t, double u,
                        double* sw, double* si) {
  if (e.Tc > 0.0 && *sw == 0.0) {
    const double net = m.K * x.i - OtherTorque(e, x, t);  // w == 0: no B w, no drag
    if (std::abs(net) > e.Tc) *sw = Sign(net);
  }
  if (e.Vdt > 0.0 && *si == 0.0) {
    const double v = u - m.K * x.w;  // i == 0: no R i
    if (std::abs(v) > e.Vdt) *si = Sign(v);
  }
}

}  // namespace detail

// Simulates from rest (i = w = theta = 0 at t = 0) under the input u (one value per sample,
// zero-order hold) sampled at fs; the record has u.size() samples, t_k = k / fs.
inline Record Simulate(const Servo& m, const Extras& e, const std::vector<double>& u, double fs,
                       int substeps = 64) {
  using detail::State;
  Record r;
  const std::size_t n = u.size();
  r.t.resize(n);
  r.u = u;
  r.i.resize(n);
  r.w.resize(n);
  r.theta.resize(n);
  State x;
  double sw = 0.0, si = 0.0;  // at rest, no current
  const double h = 1.0 / (fs * substeps);
  for (std::size_t k = 0; k < n; ++k) {
    r.t[k] = static_cast<double>(k) / fs;
    r.i[k] = x.i;
    r.w[k] = x.w;
    r.theta[k] = x.theta;
    if (k + 1 == n) break;
    for (int s = 0; s < substeps; ++s) {
      double t = r.t[k] + s * h;
      double left = h;
      for (int events = 0; left > 0.0; ++events) {
        detail::UpdateModes(m, e, x, t, u[k], &sw, &si);
        const State next = detail::Rk4(m, e, x, t, left, u[k], sw, si);
        double alpha = 1.0;
        bool stop_w = false, stop_i = false;
        if (events < 8 && e.Tc > 0.0 && sw != 0.0 && next.w * sw < 0.0) {
          alpha = x.w / (x.w - next.w);
          stop_w = true;
        }
        if (events < 8 && e.Vdt > 0.0 && si != 0.0 && next.i * si < 0.0) {
          const double a = x.i / (x.i - next.i);
          if (!stop_w || a < alpha) {
            alpha = a;
            stop_i = true;
            stop_w = false;
          } else if (a == alpha) {
            stop_i = true;
          }
        }
        if (!stop_w && !stop_i) {
          x = next;
          break;
        }
        const double part = alpha * left;
        x = detail::Rk4(m, e, x, t, part, u[k], sw, si);
        if (stop_w) {
          x.w = 0.0;
          sw = 0.0;
        }
        if (stop_i) {
          x.i = 0.0;
          si = 0.0;
        }
        t += part;
        left -= part;
      }
    }
  }
  return r;
}

// A square wave of `amplitude`, +amplitude first, switching every `half_period` samples.
inline std::vector<double> SquareWave(std::size_t samples, std::size_t half_period,
                                      double amplitude) {
  std::vector<double> u(samples);
  for (std::size_t k = 0; k < samples; ++k)
    u[k] = (k / half_period) % 2 == 0 ? amplitude : -amplitude;
  return u;
}

inline double Rms(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x * x;
  return v.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(v.size()));
}

// White Gaussian noise, sigma = fraction * RMS of the column, on i and w (and theta when
// `theta` is true), seeded.
inline void AddNoise(Record* r, double fraction, std::uint64_t seed, bool theta = false) {
  std::mt19937_64 engine(seed);
  const auto uniform = [&engine] {  // (0, 1]
    return (static_cast<double>(engine() >> 11) + 1.0) * 0x1.0p-53;
  };
  const auto normal = [&] {
    return std::sqrt(-2.0 * std::log(uniform())) * std::cos(6.283185307179586 * uniform());
  };
  std::vector<std::vector<double>*> columns = {&r->i, &r->w};
  if (theta) columns.push_back(&r->theta);
  for (auto* column : columns) {
    const double sigma = fraction * Rms(*column);
    for (double& v : *column) v += sigma * normal();
  }
}

inline double PeakToPeak(const std::vector<double>& v) {
  double lo = v.empty() ? 0.0 : v[0], hi = lo;
  for (double x : v) {
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  return hi - lo;
}

// The record as a trace CSV (t,u,i,w,theta), every number round-trip exact.
inline std::string Csv(const Record& r) {
  std::string out = "t,u,i,w,theta\n";
  char line[160];
  for (std::size_t k = 0; k < r.t.size(); ++k) {
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%.17g,%.17g\n", r.t[k], r.u[k], r.i[k],
                  r.w[k], r.theta[k]);
    out += line;
  }
  return out;
}

}  // namespace independent
