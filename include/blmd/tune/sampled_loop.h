// The digital loops of a drive around a rigid_load plant (docs/tuning.md §7): the shaft
// J dw/dt = Kt u_a − B w driven through the current (force) loop, a first-order lag
// u_a' = ω_b (u − u_a) (ideal when no bandwidth is given), sampled every Ts with a zero-order
// hold on the command and a computation delay of d samples. The plant is discretised exactly
// (ZOH: Ad = e^{A Ts}, Bd = ∫_0^Ts e^{A τ} dτ B; Franklin, Powell & Workman, Digital Control
// of Dynamic Systems, 3rd ed., 1998, ch. 4), and the loops are designed and checked on
// the frequency response at z = e^{jωTs}, not on the continuous one.
//  - speed loop: the PI C(z) = kp + ki·Ts·z/(z − 1) (the integral a backward Euler sum,
//    the sample's own error included), L_w(z) = C(z)·G_w(z)·z^{−d};
//  - position loop: a P of gain kp_position (1/s) on theta whose output is the speed
//    reference of that PI, computed at the same sample (a cascade as drives run it):
//    L_θ(z) = kp_position·T(z), T the closed speed loop from the speed reference to theta.
// A notch N(z) on the torque command (SampledDrive::notch) is part of the plant the PI sees:
// G_w(z) below is N(z) times the shaft's.
#pragma once

#include <complex>
#include <limits>
#include <memory>
#include <string>

#include "blmd/sim/effects.h"
#include "blmd/sim/notch_filter.h"
#include "blmd/tune/loop.h"

namespace blmd {

// The drive's controller timing, current loop and the notch on its torque command (in the
// loop between the PI and the plant, N(z) of notch_filter.h; not active: none).
struct SampledDrive {
  double sample_rate_hz = 0.0;        // 1/Ts, > 0
  int delay_samples = 1;              // d: computation delay, samples
  double current_bandwidth_hz = 0.0;  // ω_b/2π; 0: an ideal current loop (no lag)
  NotchFilter notch{};
  std::string Validate() const;  // "" when usable, else what is wrong (one line)
};

// J (kg·m², kg), B (N·m·s/rad, N·s/m), Kt (torque or force per unit of u): the totals; with
// inertia_ratio > 0 a flexible coupling to the load (docs/effects.md, two_mass: Jm = J/(1+r),
// Jl = J r/(1+r), K = Jl (2 pi fa)^2, c = 2 zeta Jl 2 pi fa, B split (1-s) B, s B), the loop
// measuring the motor.
struct RigidPlant {
  double J = 0.0, B = 0.0, Kt = 1.0;
  double inertia_ratio = 0.0, anti_resonance_hz = 0.0, shaft_damping_ratio = 0.0,
         load_damping_share = 0.0;
  bool two_mass() const { return inertia_ratio > 0.0 && anti_resonance_hz > 0.0; }
  TwoMassSides Sides() const {
    return TwoMassSides::Of(J, B, inertia_ratio, anti_resonance_hz, shaft_damping_ratio,
                            load_damping_share);
  }
};

// The gains in continuous-time SI units: C(z) = speed_kp + speed_ki·Ts·z/(z − 1); a drive
// that adds the integral per sample uses speed_ki·Ts. position_kp 0: the speed loop alone.
struct CascadeGains {
  double speed_kp = 0.0;     // u·s/rad (u·s/m)
  double speed_ki = 0.0;     // u/rad (u/m)
  double position_kp = 0.0;  // 1/s: speed reference per position error
};

class SampledRigidLoop {
 public:
  SampledRigidLoop(const RigidPlant& plant, const SampledDrive& drive);

  double period() const { return ts_; }
  const SampledDrive& drive() const { return drive_; }
  double nyquist_hz() const { return 0.5 / ts_; }
  // G_w(e^{jωTs})·e^{−jdωTs}: the held command to the sampled speed, delay included.
  std::complex<double> SpeedPlantAt(double omega) const;
  // The phase of SpeedPlantAt, unwrapped from 0 at ω -> 0, degrees.
  double SpeedPlantPhaseDeg(double omega) const;
  std::complex<double> PiAt(const CascadeGains& gains, double omega) const;
  std::complex<double> SpeedLoopAt(const CascadeGains& gains, double omega) const;
  std::complex<double> PositionLoopAt(const CascadeGains& gains, double omega) const;
  // The continuous loops with the same gains: no hold, no delay, the current lag kept.
  std::complex<double> ContinuousSpeedLoopAt(const CascadeGains& gains, double omega) const;
  std::complex<double> ContinuousPositionLoopAt(const CascadeGains& gains, double omega) const;
  // The closed loop's poles in the z plane (the eigenvalues of its state matrix: plant,
  // integral, delay line); stable when every |z| < 1, slowest_time_constant −Ts/ln|z|max.
  ClosedLoopPoles Poles(const CascadeGains& gains, bool position) const;

 private:
  struct Discrete;  // the plant sampled once, for the speed and the position loop
  RigidPlant plant_;
  SampledDrive drive_;
  double ts_ = 0.0;
  bool lag_ = false;
  std::shared_ptr<const Discrete> discrete_;
};

struct SampledDesignResult {
  bool ok = false;
  std::string reason;  // refused: why, with the highest (or lowest) feasible crossover
  CascadeGains gains;
  double plant_gain = std::numeric_limits<double>::quiet_NaN();            // |G_w z^-d|
  double plant_phase_deg = std::numeric_limits<double>::quiet_NaN();       // its phase
  double controller_phase_deg = std::numeric_limits<double>::quiet_NaN();  // needed
  double min_controller_phase_deg = std::numeric_limits<double>::quiet_NaN();
  // The highest crossover at which the sampled PI gives the phase margin (NaN: none).
  double highest_crossover_hz = std::numeric_limits<double>::quiet_NaN();
  double position_crossover_hz = std::numeric_limits<double>::quiet_NaN();  // cascade
};

// The speed PI that puts L_w(e^{jω_c Ts}) at e^{j(φ_m − 180°)}: with x = ω_c Ts,
// z/(z − 1) = 1/2 − j·cot(x/2)/2 on the unit circle, so C = M e^{jθ} gives
// ki = −2 M sin θ·tan(x/2)/Ts and kp = M cos θ − ki Ts/2; kp > 0 and ki >= 0 need
// −(90° − x/2) < θ <= 0. Refused otherwise, naming the edge of the feasible crossovers.
SampledDesignResult DesignSampledSpeedPi(const SampledRigidLoop& loop, double crossover_hz,
                                         double phase_margin_deg);

// The highest crossover (Hz) at which the sampled PI still gives `phase_margin_deg`: where
// the needed controller phase reaches 0 (found by bisection to 1e-9 of the frequency). NaN
// when none below the Nyquist frequency.
double HighestSampledCrossover(const SampledRigidLoop& loop, double phase_margin_deg);

// The position P over the tuned speed PI: kp_position = 1/|T(e^{jω_p Ts})|. False (and
// *reason) when the loop has no phase margin there.
bool DesignSampledPositionP(const SampledRigidLoop& loop, double position_crossover_hz,
                            CascadeGains* gains, std::string* reason);

}  // namespace blmd
