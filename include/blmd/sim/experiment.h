// What a simulation is asked to do: the input signal, the experiment around it (coast-down,
// closed loop), the initial state, and the numerics. See docs/experiments.md.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "blmd/sim/notch_filter.h"

namespace blmd {

// u(t) for the model input (dc_servo: armature voltage V; blmd: torque demand V;
// closed loop: the position reference in rad).
struct InputSignal {
  enum class Kind { kStep, kSquare, kSteps, kRecorded, kPrbs, kChirp };
  enum class ChirpShape { kLinear, kLog };
  Kind kind = Kind::kStep;
  double amplitude = 0.0;  // step height; square, prbs, chirp: half peak-to-peak
  double offset = 0.0;     // value before the step; square, prbs, chirp: mean (and before t0)
  double t0 = 0.0;         // s, step instant; square start (begins high); prbs, chirp start
  double period = 0.0;     // s, square period
  // kPrbs: a maximum-length sequence of an order-bit linear-feedback shift register with the
  // primitive feedback polynomial PrbsPolynomial(order), started from the state seed
  // (1 .. 2^order - 1). Bit k (k = 0, 1, ...) holds on [t0 + k clock, t0 + (k+1) clock):
  // offset + amplitude when it is 1, offset - amplitude when 0; it repeats every
  // 2^order - 1 bits. See docs/config.md for the register.
  double clock = 0.0;      // s, kPrbs bit duration Tc
  int order = 0;           // kPrbs register length n, 2..31
  std::uint32_t seed = 1;  // kPrbs start state, nonzero, < 2^order
  // kChirp: offset + amplitude sin(phi(t - t0)), phi(0) = 0, phi' = 2 pi f: f sweeps f0 -> f1
  // over sweep seconds (linearly or exponentially), then stays at f1. offset before t0.
  double f0 = 0.0;     // Hz
  double f1 = 0.0;     // Hz
  double sweep = 0.0;  // s, > 0
  ChirpShape shape = ChirpShape::kLinear;
  // kSteps: values[k] holds from times[k] on (offset before times[0]).
  // kRecorded: zero-order hold of recorded samples, values[k] holds on [times[k], times[k+1]).
  std::vector<double> times;
  std::vector<double> values;
  // kRecorded, dc_servo only: 1 where the armature is open (coast-down), empty if never.
  std::vector<double> open;

  // u(t). kPrbs: O(order·log k) at bit k (the register jumped there); InputCursor reads a
  // prbs at non-decreasing times in O(1) amortised.
  double At(double t) const;
  bool OpenAt(double t) const;
  // kPrbs: the bit (0 or 1) that holds at t >= t0. kChirp: phi(t) in rad and f(t) in Hz
  // (f0 before t0).
  int PrbsBit(double t) const;
  double ChirpPhase(double t) const;
  double ChirpFrequency(double t) const;
};

// The feedback polynomial of the order-n maximum-length register (n = 2..31), as the bit
// mask of p(x) = x^n + ... + 1 without its x^n term (bit j: the coefficient of x^j): the
// primitive tap sets of Xilinx XAPP052 (Alfke 1996), Table 3. 0 for another n.
std::uint32_t PrbsPolynomial(int order);

// Reads an InputSignal at non-decreasing times in O(1) amortised (no search per step).
class InputCursor {
 public:
  explicit InputCursor(const InputSignal& signal) : signal_(signal) {}
  double At(double t);
  bool OpenAt(double t);
  // The earliest time after t at which At() or OpenAt() may change (t itself when it
  // cannot tell cheaply, e.g. a square wave; +infinity when never): a fast path reads the
  // signal again only once its time reaches this. A prbs: its next bit edge at which the
  // bit changes (runs of equal bits are skipped). A chirp changes continuously: t.
  double NextChange(double t);

 private:
  void Advance(double t);
  // kPrbs: the register state of bit k, kept for the next call (stepped forward or jumped).
  std::uint32_t PrbsStateAt(std::uint64_t k);
  const InputSignal& signal_;
  std::size_t index_ = 0;
  bool prbs_ready_ = false;
  std::uint64_t prbs_index_ = 0;  // the bit whose register state prbs_state_ holds
  std::uint32_t prbs_state_ = 0;
  // Bits [prbs_run_begin_, prbs_run_end_) hold the same value; prbs_run_end_ is where it
  // changes (valid when prbs_run_end_ > prbs_run_begin_).
  std::uint64_t prbs_run_begin_ = 0, prbs_run_end_ = 0;
};

// Closed-loop control (dc_servo; rigid_load: see the fields below u_max): PID on the
// measured y (theta, or w for the speed loop), output saturated at +-u_max.
// u = Kp e + Ki integral(e) - Kd dy_f/dt, e = r - y; derivative on the measurement through a
// first-order filter (tau_d); the integrator stops while the output saturates in the
// direction of the error (clamping anti-windup).
struct PidSettings {
  // What the loop measures and the reference means: the shaft angle theta (rad, the
  // default) or the shaft speed w (rad/s). The gains' units follow: V/rad or V·s/rad, ...
  enum class Loop { kPosition, kSpeed };
  Loop loop = Loop::kPosition;
  double Kp = 0.0;      // V/rad (speed loop: V·s/rad)
  double Ki = 0.0;      // V/(rad·s) (speed loop: V/rad)
  double Kd = 0.0;      // V·s/rad (speed loop: V·s²/rad)
  double tau_d = 1e-3;  // s, derivative filter time constant
  double u_max = 24.0;  // V, saturation (the supply)
  // rigid_load: the drive's digital cascade (docs/model-rigid-load.md, docs/tuning.md §7).
  // The controller samples w and theta every 1/sample_rate s (a whole number of simulation
  // steps), its output takes effect `delay` samples later and is held (zero-order hold), and
  // the current (force) loop follows the command as a first-order lag of current_bandwidth
  // Hz (0: ideal). The speed loop is a PI (Kp u·s/rad, Ki u/rad); the position loop a P (and
  // I) on theta (Kp 1/s, Ki 1/s²) whose output is the speed reference of the inner PI
  // (speed_Kp, speed_Ki). The integrals are backward Euler sums; the speed integral is held
  // while the output saturates in the direction of the error (conditional integration). u is
  // limited to [u_min, u_max]; u_min NaN means -u_max. dc_servo reads sample_rate and delay
  // only (0: its PID on every simulation step, without delay) and ignores the rest.
  double sample_rate = 0.0;        // Hz; 0: every simulation step
  int delay = 1;                   // samples
  double current_bandwidth = 0.0;  // Hz; 0: ideal current loop
  double speed_Kp = 0.0;           // u·s/rad, position loop's inner PI
  double speed_Ki = 0.0;           // u/rad
  // Position loop: the position reference's rate (its backward difference per controller
  // sample) times this is added to the speed reference (speed feed-forward; 1: the PD with a
  // speed reference, Kp' (r - theta) + Kd' (r' - w), of many drives and lab rigs).
  double speed_feedforward = 0.0;
  // The speed the controller feeds back: 0, the measured w; N >= 1, the difference of the
  // sampled angle over N controller samples, (theta_k - theta_{k-N}) / (N Ts), as drives that
  // read only an encoder estimate it (N = 2: the mean of two one-sample differences).
  int speed_difference_samples = 0;
  double u_min = std::numeric_limits<double>::quiet_NaN();  // NaN: -u_max
  // A notch on the speed PI's output, the torque (force) command, before the limit
  // (notch_filter.h); not active: none.
  NotchFilter notch{};
  double LowerLimit() const { return std::isnan(u_min) ? -u_max : u_min; }
};

struct InitialState {
  double i = 0.0;      // A
  double w = 0.0;      // rad/s
  double theta = 0.0;  // rad
  // A two-mass shaft's load (docs/effects.md, two_mass): its speed (rad/s; unset: the motor's)
  // and the twist theta - theta_load (rad). A record starts with the load turning with the
  // motor, untwisted; a part cut from the middle of a record (discovery's cross-validation)
  // starts where the model's own simulation had them.
  std::optional<double> w_load;
  double twist = 0.0;
  double LoadSpeed() const { return w_load.value_or(w); }
};

struct Experiment {
  InputSignal input;
  double duration = 1.0;         // s
  double sample_rate = 10000.0;  // Hz, output rate
  // Why this experiment cannot be run as configured (its sample rate beyond 1/dt, a run too
  // long), as the one-line error naming the config's line and column; empty when it can.
  // Set at load, thrown only by those that run it (CheckRunnable): a trace brings its own
  // time base.
  std::string invalid;
  void CheckRunnable() const;
  double coast_off_time = -1.0;  // s; >= 0: dc_servo armature opened at this instant
  bool closed_loop = false;
  PidSettings pid;
  InitialState initial;

  // Sample instants 0, 1/fs, ..., duration.
  std::vector<double> SampleTimes() const;
};

// How a model's equations are integrated (docs/model-blmd.md §5 and §9).
//   kFixedEuler  a fixed step dt (every model; the default but for blmd): dc_servo and
//                rigid_load advance their linear part exactly over each step with the input
//                and effect torques held (docs/model-dc-servo.md, "Exact discretisation");
//                the blmd drive's sub-systems by backward Euler (docs/model-blmd.md §5). The
//                name is the config's, kept for the configs that use it.
//   kEvents      blmd only (its default, Model::default_settings): the PWM and diode switching
//   instants located to rounding, a
//                Taylor series of the smooth drive between them (second order for the
//                windings and compensators, third for the speed), samples read
//                from the series at their exact instants (docs/model-blmd.md §9)
enum class SimulationMethod { kEvents, kFixedEuler };

// The method names of the config's simulation.method, sorted (the one registry of them).
inline const std::vector<std::pair<std::string, SimulationMethod>>& SimulationMethods() {
  static const std::vector<std::pair<std::string, SimulationMethod>> methods = {
      {"events", SimulationMethod::kEvents}, {"fixed_euler", SimulationMethod::kFixedEuler}};
  return methods;
}

// A method's name in the config (the registry's entry for it).
inline const std::string& SimulationMethodName(SimulationMethod method) {
  const auto& methods = SimulationMethods();
  for (const auto& entry : methods) {
    if (entry.second == method) return entry.first;
  }
  return methods.back().first;  // not reached: every method is in the registry
}

struct SimulationSettings {
  double dt = 1e-5;  // s, fixed integration step
  SimulationMethod method = SimulationMethod::kFixedEuler;
  // s, events method: the longest stretch one Taylor series spans between switching events
  // (its accuracy knob: the local error is O(max_step^3) in the currents, O(max_step^4) in
  // the speed); 0 means the default, Tpwm/2.
  double max_step = 0.0;
  bool regula_falsi = true;           // blmd: locate PWM crossings inside a step
  double friction_smoothing_w = 0.0;  // rad/s; > 0 replaces sign(w) by tanh(w/eps)
  bool diagnostics = false;           // add internal columns (phase voltages, torque)
  double divergence_limit = 1e9;      // |state| above this is a divergence
  // Position-dependent effects (cogging) evaluated at this angle (rad), given at the request's
  // sample times and interpolated linearly, instead of at the simulated angle: the
  // "series-parallel" (teacher-forced) model discovery uses to fit cogging against a measured
  // angle (docs/discovery.md). nullptr: the simulated angle. Borrowed for the call.
  const std::vector<double>* effect_angle = nullptr;
};

}  // namespace blmd
