// The dc_servo model's fast path: SimulateReference (dc_servo.cc) with the exact
// discretisation's matrices unrolled into scalars, the input read again only when it can
// change (InputCursor::NextChange), and outputs written only at the sample steps
// (docs/performance.md). No allocation, virtual call or look-up inside the step loop.
//
// Macro steps: while the model is linear (no friction, drag, cogging or dead time, open
// loop, armature closed) and the input holds, n steps of x+ = Ad x + Bd v are one step
// x+ = Ad^n x + (sum_k<n Ad^k) Bd v, with the matrices composed from powers made once per
// run by doubling. That is the same discrete model (the reference's steps, not a coarser one):
// it differs from stepping one at a time only by rounding (tests/fast_path_test.cc).
//
// The step loop (Simulate) calls the steps below, each always inlined, so that the loop
// compiles to the arithmetic it had when it was written out in one function.
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "blmd/sim/dc_servo.h"
#include "blmd/sim/effects.h"
#include "sim/dc_servo_steps.h"
#include "sim/plain_shaft.h"
#include "sim/sampler.h"

namespace blmd {
namespace {

#define BLMD_STEP_INLINE [[gnu::always_inline]] inline

// x+ = P x + G v for n steps at once: P = Ad^n, G = (sum_k<n Ad^k) Bd (row-major).
struct MacroStep {
  std::array<double, 9> P;
  std::array<double, 6> G;
};

// The macro steps of one run: Ad^(2^m) and its sums by doubling, and any n composed from
// them by its binary digits (powers of Ad commute, so the order does not matter). The last
// few n asked for are kept: the gap between samples repeats, so one composition serves a
// whole run.
class MacroSteps {
 public:
  MacroSteps(const Eigen::Matrix3d& Ad, const Eigen::Matrix<double, 3, 2>& Bd, long max_steps) {
    powers_.push_back({Ad, Bd});
    while ((max_steps >> powers_.size()) != 0) Double();
  }

  const MacroStep& For(long n) {
    for (std::size_t k = 0; k < kCached; ++k) {
      if (cached_n_[k] == n) return cached_[k];
    }
    while ((n >> powers_.size()) != 0) Double();  // not reached for n within the run
    Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
    Eigen::Matrix<double, 3, 2> G = Eigen::Matrix<double, 3, 2>::Zero();
    for (std::size_t m = 0; (n >> m) != 0; ++m) {
      if (((n >> m) & 1) == 0) continue;
      G = (powers_[m].P * G + powers_[m].G).eval();
      P = (powers_[m].P * P).eval();
    }
    const std::size_t slot = next_slot_;
    next_slot_ = (next_slot_ + 1) % kCached;
    cached_n_[slot] = n;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) cached_[slot].P[3 * r + c] = P(r, c);
      for (int c = 0; c < 2; ++c) cached_[slot].G[2 * r + c] = G(r, c);
    }
    return cached_[slot];
  }

 private:
  struct Power {
    Eigen::Matrix3d P;
    Eigen::Matrix<double, 3, 2> G;
  };
  // Appends 2^(m+1) steps from the last 2^m: the first span's input, then the second's.
  void Double() {
    const Power& last = powers_.back();
    powers_.push_back({(last.P * last.P).eval(), (last.G + last.P * last.G).eval()});
  }
  static constexpr std::size_t kCached = 4;
  std::vector<Power> powers_;  // [m]: 2^m steps
  std::array<long, kCached> cached_n_ = {-1, -1, -1, -1};
  std::array<MacroStep, kCached> cached_{};
  std::size_t next_slot_ = 0;
};

// The state x = [i, w, theta] (A, rad/s, rad).
struct DcState {
  double i, w, theta;
};

// The three discretisations (internal::DcServoDiscretisation) read out as scalars: the full
// system's a_rc = Ad(r, c), b_rc = Bd(r, c), the stuck armature's and the open shaft's.
struct DcScalars {
  double a00, a01, a02, a10, a11, a12, a20, a21, a22;
  double b00, b01, b10, b11, b20, b21;
  double stuck_a, stuck_b;
  double open_a00, open_a01, open_a10, open_a11, open_b0, open_b1;
  bool theta_decoupled;  // a02 = a12 = 0, a22 = 1 exactly: theta feeds neither i nor w

  static DcScalars From(const internal::DcServoDiscretisation& d) {
    DcScalars s;
    s.a00 = d.Ad(0, 0), s.a01 = d.Ad(0, 1), s.a02 = d.Ad(0, 2);
    s.a10 = d.Ad(1, 0), s.a11 = d.Ad(1, 1), s.a12 = d.Ad(1, 2);
    s.a20 = d.Ad(2, 0), s.a21 = d.Ad(2, 1), s.a22 = d.Ad(2, 2);
    s.b00 = d.Bd(0, 0), s.b01 = d.Bd(0, 1), s.b10 = d.Bd(1, 0), s.b11 = d.Bd(1, 1);
    s.b20 = d.Bd(2, 0), s.b21 = d.Bd(2, 1);
    s.stuck_a = d.Ads(0, 0), s.stuck_b = d.Bds(0, 0);
    s.open_a00 = d.Ado(0, 0), s.open_a01 = d.Ado(0, 1), s.open_a10 = d.Ado(1, 0);
    s.open_a11 = d.Ado(1, 1), s.open_b0 = d.Bdo(0, 0), s.open_b1 = d.Bdo(1, 0);
    s.theta_decoupled = s.a02 == 0.0 && s.a12 == 0.0 && s.a22 == 1.0;
    return s;
  }
};

// Coulomb friction alone (no Stribeck, smoothing, drag or cogging), open loop, no dead time:
// while the shaft turns one way the friction is the constant +-Tc, the model linear again,
// and macro steps apply over any stretch in which w provably keeps its sign. The proof
// needs the (i, w) block's eigenvalues real and positive (an overdamped armature-shaft
// pair; Ad = exp(A dt) of real eigenvalues): then w's step-to-step change under a constant
// input is c1 l1^k + c2 l2^k, which changes sign at most once, so when the first and last
// changes of a stretch agree in sign w is monotone over it, and w at both ends of the
// stretch having the start's sign means every step in between has it too.
bool CoulombMacroStepsApply(const ShaftEffects& shaft, const DriveEffects& drive, bool closed_loop,
                            const DcScalars& s) {
  const double block_trace = s.a00 + s.a11, block_det = s.a00 * s.a11 - s.a01 * s.a10;
  return shaft.Tc > 0.0 && shaft.Ts == 0.0 && shaft.smoothing_w <= 0.0 && shaft.Tcog == 0.0 &&
         shaft.Cd == 0.0 && shaft.dB == 0.0 && drive.Vdt == 0.0 && !closed_loop &&
         s.theta_decoupled && block_trace > 0.0 && block_det > 0.0 &&
         block_trace * block_trace - 4.0 * block_det >= 0.0;
}

// The input over [t, t + dt) read at t + dt/2 (as the reference), but only again once that
// time reaches the signal's next change; and the controller that turns it into the voltage.
class FastControl {
 public:
  FastControl(const Experiment& experiment, double dt, double theta)
      : input_(experiment.input),
        pid_settings_(experiment.pid),
        closed_loop_(experiment.closed_loop),
        dt_(dt),
        alpha_(dt / (experiment.pid.tau_d + dt)) {
    pid_.derivative_state = theta;
  }

  double next_change() const { return next_change_; }
  bool input_open() const { return open_; }

  // The voltage over [t, t + dt) from the state at t; *reference: the input there.
  BLMD_STEP_INLINE double Control(double t, double theta, double* reference) {
    Read(t + 0.5 * dt_);
    const double r = value_;
    *reference = r;
    if (!closed_loop_) return r;
    return pid_.Control(pid_settings_, alpha_, dt_, r, theta);
  }

 private:
  BLMD_STEP_INLINE void Read(double t_mid) {
    if (t_mid >= next_change_) {
      value_ = input_.At(t_mid);
      open_ = input_.OpenAt(t_mid);
      next_change_ = input_.NextChange(t_mid);
    }
  }

  InputCursor input_;
  const PidSettings& pid_settings_;
  const bool closed_loop_;
  const double dt_, alpha_;
  internal::DcServoPid pid_;
  double value_ = 0.0, next_change_ = -1e300;
  bool open_ = false;
};

// Where a macro step from a given step must end: before the step that reads a new input
// value (its middle reaches the next change) or opens the armature, and at the end of the
// step that records the next sample when the sample falls there, else before that step
// (whose start state the sampler interpolates from). The step indices are found by the
// loop's own arithmetic and kept while their threshold holds.
class MacroStepPlan {
 public:
  MacroStepPlan(double t_start, double dt, double coast_off_time, bool has_coast)
      : t_start_(t_start), dt_(dt), inv_dt_(1.0 / dt) {
    coast_step_ =
        has_coast ? FirstStep(coast_off_time, 0.5 * dt) : std::numeric_limits<long>::max() / 2;
  }

  // After a stretch whose sign proof failed, single steps up to its end (one attempt per
  // stretch: a failed proof costs three small matrix products, not three per step).
  long single_steps_until = 0;

  // The number of steps from `step` that may be one macro step.
  BLMD_STEP_INLINE long Span(long step, double record_at, const internal::OutputSampler& sampler,
                             double input_next_change) {
    if (record_at != record_step_for_) {
      record_step_ = FirstStep(record_at, 0.0) - 1;  // the recording step's index
      record_step_for_ = record_at;
      const double step_start = t_start_ + static_cast<double>(record_step_) * dt_;
      const double step_end = t_start_ + static_cast<double>(record_step_ + 1) * dt_;
      sample_on_step_end_ =
          (sampler.next_time() - step_start) / (step_end - step_start) > 1.0 - 1e-9;
    }
    if (input_next_change != change_step_for_) {
      change_step_ = FirstStep(input_next_change, 0.5 * dt_);
      change_step_for_ = input_next_change;
    }
    const long last = sample_on_step_end_ ? record_step_ + 1 : record_step_;
    return std::min({last, change_step_, coast_step_}) - step;
  }

 private:
  // The first step index s whose time t_start + s dt, plus offset, reaches threshold, by the
  // loop's own arithmetic (so the macro steps stop exactly where single steps would act).
  BLMD_STEP_INLINE long FirstStep(double threshold, double offset) const {
    if (!(threshold < 1e299)) return std::numeric_limits<long>::max() / 2;
    auto at = [&](long s) { return t_start_ + static_cast<double>(s) * dt_ + offset; };
    const double estimate = (threshold - offset - t_start_) * inv_dt_;  // then exact by the loops
    long s = estimate > 0.0 ? static_cast<long>(estimate) : 0;
    while (s > 0 && at(s - 1) >= threshold) --s;
    while (at(s) < threshold) ++s;
    return s;
  }

  const double t_start_, dt_, inv_dt_;
  long coast_step_;  // the first step with the armature open
  double record_step_for_ = -1.0, change_step_for_ = -1.0;
  long record_step_ = 0, change_step_ = 0;
  // Whether the sample falls on the recording step's end (the sampler's alpha = 1, the usual
  // case of samples on the step grid): then the state before that step is never read and the
  // macro step may include the recording step.
  bool sample_on_step_end_ = false;
};

enum class MacroOutcome {
  kTaken,         // *end holds the state after the n steps
  kSignUnproved,  // w may reach zero inside the stretch: single steps, which stop or stick it
  kDiverging,     // the end state is past the limit: single steps from here on
};

// n >= 2 steps from x under the voltage u as one macro step. `linear`: no friction (else
// Coulomb friction of w's sign, which must provably hold over the stretch).
BLMD_STEP_INLINE MacroOutcome MacroStepFrom(MacroSteps& macro, long n, const DcState& x, double u,
                                            bool linear, const ShaftEffects& shaft,
                                            const DcScalars& s, double i0, double limit,
                                            double end[3]) {
  const double i = x.i, w = x.w, theta = x.theta;
  const MacroStep& macro_step = macro.For(n);
  const double* P = macro_step.P.data();
  const double* G = macro_step.G.data();
  // T_effects as the single steps sum it: the load, plus the friction of w's sign.
  const double load = linear ? shaft.TL : (w > 0.0 ? shaft.Tc : -shaft.Tc) + shaft.TL;
  end[0] = P[0] * i + P[1] * w + P[2] * theta + (G[0] * u + G[1] * load);
  end[1] = P[3] * i + P[4] * w + P[5] * theta + (G[2] * u + G[3] * load);
  end[2] = P[6] * i + P[7] * w + P[8] * theta + (G[4] * u + G[5] * load);
  bool keeps_sign = true;
  if (!linear) {
    // w after the first step and before the last (macro_step's data may be reused by
    // For below: end is already computed).
    const double w_first = s.a10 * i + s.a11 * w + s.a12 * theta + (s.b10 * u + s.b11 * load);
    const MacroStep& but_one = macro.For(n - 1);
    const double w_before_last = but_one.P[3] * i + but_one.P[4] * w + but_one.P[5] * theta +
                                 (but_one.G[2] * u + but_one.G[3] * load);
    const double sign = w > 0.0 ? 1.0 : -1.0, w_last = end[1];
    keeps_sign = sign * w_first > 0.0 && sign * w_before_last > 0.0 && sign * w_last > 0.0 &&
                 (w_first - w) * (w_last - w_before_last) >= 0.0;
  }
  if (!keeps_sign) return MacroOutcome::kSignUnproved;
  if (internal::AllFinite(end, 3, limit) && std::abs(end[0] + i0) <= limit) {
    return MacroOutcome::kTaken;
  }
  return MacroOutcome::kDiverging;
}

// n >= 2 steps from `step` as one macro step: returns n (x then at their end), or 1 when a
// single step is due: w may reach zero inside the stretch (single steps up to its end, which
// stop or stick it), or the end state is past the limit (single steps from here on, so that
// the run ends at the first step past the limit, as the reference does).
BLMD_STEP_INLINE long MacroAdvance(long n, long step, MacroSteps& macro, double u,
                                   const ShaftEffects& shaft, const DcScalars& s, double i0,
                                   double limit, bool* linear, bool* coulomb_macro,
                                   MacroStepPlan* plan, DcState* x) {
  double end[3];  // i, w, theta at the macro step's end
  switch (MacroStepFrom(macro, n, *x, u, *linear, shaft, s, i0, limit, end)) {
    case MacroOutcome::kTaken:
      *x = {end[0], end[1], end[2]};
      return n;
    case MacroOutcome::kSignUnproved:
      plan->single_steps_until = step + n;
      return 1;
    case MacroOutcome::kDiverging:
      *linear = *coulomb_macro = false;
      return 1;
  }
  return 1;
}

// The voltage the armature sees: u less the dead time's Vdt sign(i).
BLMD_STEP_INLINE double DeadTimeVoltage(const DriveEffects& drive, double u, double i) {
  return drive.Vdt == 0.0 ? u : u - drive.Vdt * (i > 0.0 ? 1.0 : (i < 0.0 ? -1.0 : 0.0));
}

// One step without friction, drag or cogging: T_effects = TL, one matrix step. The input
// terms do not depend on the state, so they are off the step-to-step dependency chain; when
// theta does not feed i or w (theta_decoupled) the chain from one step's state to the next
// is a multiply, a fused multiply-add and an add.
BLMD_STEP_INLINE void PlainStep(const DcScalars& s, double load, double u_eff, DcState* x) {
  double& i = x->i;
  double& w = x->w;
  double& theta = x->theta;
  const double in0 = s.b00 * u_eff + s.b01 * load, in1 = s.b10 * u_eff + s.b11 * load,
               in2 = s.b20 * u_eff + s.b21 * load;
  if (s.theta_decoupled) {
    const double i1 = (s.a00 * i + s.a01 * w) + in0;
    const double w1 = (s.a10 * i + s.a11 * w) + in1;
    theta += (s.a20 * i + s.a21 * w) + in2;
    i = i1;
    w = w1;
  } else {
    const double i1 = s.a00 * i + s.a01 * w + s.a02 * theta + in0;
    const double w1 = s.a10 * i + s.a11 * w + s.a12 * theta + in1;
    const double th1 = s.a20 * i + s.a21 * w + s.a22 * theta + in2;
    i = i1;
    w = w1;
    theta = th1;
  }
}

// One step with the shaft's effects (friction with sticking, drag, cogging), the armature
// closed or open (i = 0); a shaft that friction stops inside the step ends it at rest.
BLMD_STEP_INLINE void EffectStep(const DcScalars& s, const ShaftEffects& shaft, double Kt,
                                 double dt, bool open, double u_eff, DcState* x) {
  double& i = x->i;
  double& w = x->w;
  double& theta = x->theta;
  const double w_old = w, theta_old = theta;
  const double non_friction = shaft.NonFrictionTorque(theta) + shaft.DragTorque(w);
  if (open) {
    i = 0.0;
    bool stuck = false;
    const double friction = shaft.StepFriction(w, -non_friction, &stuck);
    if (!stuck) {
      const double torque = friction + non_friction;
      const double w1 = s.open_a00 * w + s.open_a01 * theta + s.open_b0 * torque;
      const double th1 = s.open_a10 * w + s.open_a11 * theta + s.open_b1 * torque;
      w = w1;
      theta = th1;
    }
  } else {
    bool stuck = false;
    const double friction = shaft.StepFriction(w, Kt * i - non_friction, &stuck);
    if (stuck) {
      i = s.stuck_a * i + s.stuck_b * u_eff;
    } else {
      const double torque = friction + non_friction;
      const double i1 = s.a00 * i + s.a01 * w + s.a02 * theta + (s.b00 * u_eff + s.b01 * torque);
      const double w1 = s.a10 * i + s.a11 * w + s.a12 * theta + (s.b10 * u_eff + s.b11 * torque);
      const double th1 = s.a20 * i + s.a21 * w + s.a22 * theta + (s.b20 * u_eff + s.b21 * torque);
      i = i1;
      w = w1;
      theta = th1;
    }
  }
  if (shaft.StopsWithin(w_old, w)) {
    const double fraction = w_old / (w_old - w);
    theta = theta_old + 0.5 * w_old * fraction * dt;
    w = 0.0;
  }
}

// The output row: u, i (as measured, with the offset i0), w, theta, r.
BLMD_STEP_INLINE void PackRow(double u, double i_out, const DcState& x, double reference,
                              double row[5]) {
  row[0] = u;
  row[1] = i_out;
  row[2] = x.w;
  row[3] = x.theta;
  row[4] = reference;
}

// The output columns besides t (r: the closed loop's reference).
std::vector<std::string> OutputNames(bool closed_loop) {
  std::vector<std::string> names = {"u", "i", "w", "theta"};
  if (closed_loop) names.emplace_back("r");
  return names;
}

// Open loop: the u column is the input at the sample times (sample times increase: no
// search per sample).
void WriteInputColumn(const Experiment& experiment, const std::vector<double>& times, Trace* out) {
  auto& u_column = out->Column("u");
  InputCursor u_cursor(experiment.input);
  for (std::size_t k = 0; k < times.size(); ++k) u_column[k] = u_cursor.At(times[k]);
}

}  // namespace

SimStatus DcServoModel::Simulate(const SimulationRequest& request, Trace* out) const {
  if (internal::ForcedEffectAngle(request.settings)) return SimulateReference(request, out);
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const double Kt = request.parameters->Get("Kt");
  const ShaftEffects shaft = ShaftEffects::From(*request.parameters, *request.effects,
                                                request.settings.friction_smoothing_w);
  const DriveEffects drive = DriveEffects::From(*request.parameters, *request.effects);
  const double limit = request.settings.divergence_limit;
  // The same three discretisations as the reference, read out as scalars.
  const internal::DcServoDiscretisation discrete =
      internal::DcServoDiscretisation::From(*request.parameters, dt);
  const DcScalars s = DcScalars::From(discrete);
  const bool plain_shaft = internal::PlainShaft(shaft);
  const bool closed_loop = experiment.closed_loop;
  const bool has_coast = experiment.coast_off_time >= 0.0;

  internal::OutputSampler sampler(times, OutputNames(closed_loop));

  const double t_start = times.front();
  DcState x = {experiment.initial.i, experiment.initial.w, experiment.initial.theta};
  FastControl control(experiment, dt, x.theta);
  double reference = 0.0;
  double u = control.Control(t_start, x.theta, &reference);
  double prev[5], now[5];
  PackRow(u, x.i + drive.i0, x, reference, prev);
  sampler.Record(t_start, prev, t_start, prev);
  auto next_record_time = [&] { return sampler.done() ? 1e300 : sampler.next_time() - 1e-9 * dt; };
  double record_at = next_record_time();

  bool linear = plain_shaft && drive.Vdt == 0.0 && !closed_loop;  // macro steps allowed
  bool coulomb_macro = CoulombMacroStepsApply(shaft, drive, closed_loop, s);
  const long total_steps = std::lround((times.back() - t_start) / dt) + 1;
  std::optional<MacroSteps> macro;
  if (linear || coulomb_macro) macro.emplace(discrete.Ad, discrete.Bd, total_steps);
  MacroStepPlan plan(t_start, dt, experiment.coast_off_time, has_coast);

  long advance = 1;  // steps taken by this iteration
  for (long step = 0; !sampler.done(); step += advance) {
    const double t_mid = t_start + static_cast<double>(step) * dt + 0.5 * dt;
    // The open flag is read at t_mid; Control() already read the input there.
    const bool open = (has_coast && t_mid >= experiment.coast_off_time) || control.input_open();
    advance = 1;
    if ((linear || (coulomb_macro && x.w != 0.0 && step >= plan.single_steps_until)) && !open) {
      const long n = plan.Span(step, record_at, sampler, control.next_change());
      if (n >= 2) {
        advance = MacroAdvance(n, step, *macro, u, shaft, s, drive.i0, limit, &linear,
                               &coulomb_macro, &plan, &x);
      }
    }
    if (advance == 1) {
      const double u_eff = DeadTimeVoltage(drive, u, x.i);
      if (plain_shaft && !open) {
        PlainStep(s, shaft.TL, u_eff, &x);
      } else {
        EffectStep(s, shaft, Kt, dt, open, u_eff, &x);
      }
    }

    const double t_next = t_start + static_cast<double>(step + advance) * dt;
    u = control.Control(t_next, x.theta, &reference);
    const double i_out = x.i + drive.i0;
    if (!(std::abs(i_out) <= limit && std::abs(x.w) <= limit && std::abs(x.theta) <= limit)) {
      return {SimStatus::Code::kDiverged, internal::DivergedMessage(limit), t_next};
    }
    if (t_next >= record_at) {
      PackRow(u, i_out, x, reference, now);
      // The recording step's start (t itself after a single step; after a macro step that
      // ends on the sample, prev is not read: the sample is at the step's end).
      sampler.Record(t_start + static_cast<double>(step + advance - 1) * dt, prev, t_next, now);
      record_at = next_record_time();
    }
    // The state before the step that records (after a macro step always: it may end there).
    if (advance > 1 || t_next + dt >= record_at) PackRow(u, i_out, x, reference, prev);
  }
  sampler.Finish(out);
  if (!closed_loop) WriteInputColumn(experiment, times, out);
  return SimStatus::Ok();
}

#undef BLMD_STEP_INLINE

}  // namespace blmd
