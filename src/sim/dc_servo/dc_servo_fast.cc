// The dc_servo model's fast path: SimulateReference (dc_servo.cc) with the exact
// discretisation's matrices unrolled into scalars, the input read again only when it can
// change (InputCursor::NextChange), and outputs written only at the sample steps
// (docs/performance.md). No allocation, virtual call or look-up inside the step loop.
//
// Macro steps: while the model is linear (no friction, drag, cogging or dead time, open
// loop, armature closed) and the input holds, n steps of x+ = Ad x + Bd v are one step
// x+ = Ad^n x + (sum_k<n Ad^k) Bd v, with the matrices composed from powers made once per
// run by doubling. That is the same discrete model (the reference's steps, not a coarser one):
// it differs from stepping one at a time only by rounding (tests/unit/fast_path_test.cc).
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "blmd/sim/dc_servo/dc_servo.h"
#include "blmd/sim/effects.h"
#include "sim/dc_servo/dc_servo_steps.h"
#include "sim/discretise.h"
#include "sim/input_read.h"
#include "sim/plain_shaft.h"
#include "sim/sampler.h"

namespace blmd {
namespace {

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

}  // namespace

SimStatus DcServoModel::Simulate(const SimulationRequest& request, Trace* out) const {
  if (internal::ForcedEffectAngle(request.settings)) return SimulateReference(request, out);
  if (ShaftEffects::From(*request.parameters, *request.effects, 0.0).two_mass()) {
    return SimulateReference(request, out);
  }
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const double R = values.Get("R"), L = values.Get("L"), Kt = values.Get("Kt"),
               Kb = values.Get("Kb"), J = values.Get("J"), B = values.Get("B");
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  const DriveEffects drive = DriveEffects::From(values, *request.effects);
  const double limit = request.settings.divergence_limit;

  // The same three discretisations as the reference (x = [i, w, theta]; stuck: [i];
  // open: [w, theta]), then read out as scalars.
  Eigen::Matrix3d A;
  A << -R / L, -Kb / L, 0.0, Kt / J, -B / J, 0.0, 0.0, 1.0, 0.0;
  Eigen::Matrix<double, 3, 2> Bm;
  Bm << 1.0 / L, 0.0, 0.0, -1.0 / J, 0.0, 0.0;
  Eigen::Matrix3d Ad;
  Eigen::Matrix<double, 3, 2> Bd;
  internal::Discretise<3, 2>(A, Bm, dt, &Ad, &Bd);
  Eigen::Matrix<double, 1, 1> As, Ads, Bs, Bds;
  As << -R / L;
  Bs << 1.0 / L;
  internal::Discretise<1, 1>(As, Bs, dt, &Ads, &Bds);
  Eigen::Matrix2d Ao, Ado;
  Eigen::Matrix<double, 2, 1> Bo, Bdo;
  Ao << -B / J, 0.0, 1.0, 0.0;
  Bo << -1.0 / J, 0.0;
  internal::Discretise<2, 1>(Ao, Bo, dt, &Ado, &Bdo);
  const double a00 = Ad(0, 0), a01 = Ad(0, 1), a02 = Ad(0, 2), a10 = Ad(1, 0), a11 = Ad(1, 1),
               a12 = Ad(1, 2), a20 = Ad(2, 0), a21 = Ad(2, 1), a22 = Ad(2, 2);
  const double b00 = Bd(0, 0), b01 = Bd(0, 1), b10 = Bd(1, 0), b11 = Bd(1, 1), b20 = Bd(2, 0),
               b21 = Bd(2, 1);
  const double stuck_a = Ads(0, 0), stuck_b = Bds(0, 0);
  const double open_a00 = Ado(0, 0), open_a01 = Ado(0, 1), open_a10 = Ado(1, 0),
               open_a11 = Ado(1, 1), open_b0 = Bdo(0, 0), open_b1 = Bdo(1, 0);
  const bool theta_decoupled = a02 == 0.0 && a12 == 0.0 && a22 == 1.0;
  const bool plain_shaft = internal::PlainShaft(shaft);

  const bool closed_loop = experiment.closed_loop;
  const PidSettings& pid = experiment.pid;
  const bool has_coast = experiment.coast_off_time >= 0.0;

  std::vector<std::string> names = {"u", "i", "w", "theta"};
  if (closed_loop) names.emplace_back("r");
  internal::OutputSampler sampler(times, names);

  InputCursor input(experiment.input);
  const double t_start = times.front();
  double i = experiment.initial.i, w = experiment.initial.w, theta = experiment.initial.theta;
  // The measured y of the loop: theta, or w for the speed loop (experiment.h).
  const bool speed_loop = pid.loop == PidSettings::Loop::kSpeed;
  double integral = 0.0, derivative_state = speed_loop ? w : theta;
  const double alpha = dt / (pid.tau_d + dt);
  // A digital controller (pid.sample_rate): sampled, delayed and held (dc_servo_steps.h).
  std::optional<internal::SampledDcServoPid> sampled;
  if (closed_loop && pid.sample_rate > 0.0) sampled.emplace(pid, dt, derivative_state);

  // The input over [t, t + dt) is read at t + dt/2 (as the reference), but only again once
  // that time reaches the signal's next change.
  double input_value = 0.0, input_next_change = -1e300;
  bool input_open = false;
  auto read_input = [&](double t_mid) {
    if (t_mid >= input_next_change) {
      input_value = input.At(t_mid);
      input_open = input.OpenAt(t_mid);
      input_next_change = input.NextChange(t_mid);
    }
  };
  auto control = [&](double t, double* reference) {
    read_input(internal::InputReadTime(t, dt));
    const double r = input_value;
    *reference = r;
    if (!closed_loop) return r;
    const double y = speed_loop ? w : theta;
    if (sampled) return sampled->Step(r, y);
    const double error = r - y;
    const double filtered_prev = derivative_state;
    derivative_state += alpha * (y - derivative_state);
    const double dy = (derivative_state - filtered_prev) / dt;
    double u = pid.Kp * error + pid.Ki * integral - pid.Kd * dy;
    const bool saturated_high = u > pid.u_max, saturated_low = u < -pid.u_max;
    if (!((saturated_high && error > 0.0) || (saturated_low && error < 0.0))) {
      integral += error * dt;
    }
    return std::clamp(u, -pid.u_max, pid.u_max);
  };

  double reference = 0.0;
  double u = control(t_start, &reference);
  double prev[5] = {u, i + drive.i0, w, theta, reference}, now[5];
  sampler.Record(t_start, prev, t_start, prev);
  auto next_record_time = [&] { return sampler.done() ? 1e300 : sampler.next_time() - 1e-9 * dt; };
  double record_at = next_record_time();

  bool linear = plain_shaft && drive.Vdt == 0.0 && !closed_loop;  // macro steps allowed
  // Coulomb friction alone (no Stribeck, smoothing, drag, cogging, spring or gravity), open loop,
  // no dead time: while the shaft turns one way the friction is the constant +-Tc, the model linear
  // again, and macro steps apply over any stretch in which w provably keeps its sign. The proof
  // needs the (i, w) block's eigenvalues real and positive (an overdamped armature-shaft
  // pair; Ad = exp(A dt) of real eigenvalues): then w's step-to-step change under a constant
  // input is c1 l1^k + c2 l2^k, which changes sign at most once, so when the first and last
  // changes of a stretch agree in sign w is monotone over it, and w at both ends of the
  // stretch having the start's sign means every step in between has it too.
  const double block_trace = a00 + a11, block_det = a00 * a11 - a01 * a10;
  bool coulomb_macro = shaft.Tc > 0.0 && shaft.Ts == 0.0 && shaft.smoothing_w <= 0.0 &&
                       !shaft.position_dependent() && shaft.Cd == 0.0 && shaft.dB == 0.0 &&
                       drive.Vdt == 0.0 && !closed_loop && theta_decoupled && block_trace > 0.0 &&
                       block_det > 0.0 && block_trace * block_trace - 4.0 * block_det >= 0.0;
  const long total_steps = std::lround((times.back() - t_start) / dt) + 1;
  std::optional<MacroSteps> macro;
  if (linear || coulomb_macro) macro.emplace(Ad, Bd, total_steps);
  // After a stretch whose sign proof failed, single steps up to its end (one attempt per
  // stretch: a failed proof costs three small matrix products, not three per step).
  long single_steps_until = 0;
  // The first step index s whose start t_start + s dt (or, `at_read`, whose input read
  // instant) reaches threshold, by the loop's own arithmetic (so the macro steps stop exactly
  // where single steps would act).
  const double inv_dt = 1.0 / dt;
  auto first_step = [&](double threshold, bool at_read) -> long {
    if (!(threshold < 1e299)) return std::numeric_limits<long>::max() / 2;
    auto at = [&](long s) {
      const double t = t_start + static_cast<double>(s) * dt;
      return at_read ? internal::InputReadTime(t, dt) : t;
    };
    const double offset = at_read ? internal::kInputReadFraction * dt : 0.0;
    const double estimate = (threshold - offset - t_start) * inv_dt;  // then exact by the loops
    long s = estimate > 0.0 ? static_cast<long>(estimate) : 0;
    while (s > 0 && at(s - 1) >= threshold) --s;
    while (at(s) < threshold) ++s;
    return s;
  };
  // Steps from which on a single step is due: the one that records a sample (its end reaches
  // record_at), the one that reads a new input (its middle reaches the next change), the
  // first with the armature open.
  const long coast_step = has_coast ? first_step(experiment.coast_off_time, true)
                                    : std::numeric_limits<long>::max() / 2;
  double record_step_for = -1.0, change_step_for = -1.0;
  long record_step = 0, change_step = 0;
  // Whether the sample falls on the recording step's end (the sampler's alpha = 1, the usual
  // case of samples on the step grid): then the state before that step is never read and the
  // macro step may include the recording step.
  bool sample_on_step_end = false;

  long advance = 1;  // steps taken by this iteration
  for (long step = 0; !sampler.done(); step += advance) {
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_mid = internal::InputReadTime(t, dt);
    // The open flag is read at t_mid; control() already read the input there.
    const bool open = (has_coast && t_mid >= experiment.coast_off_time) || input_open;
    // Steps step .. step + n - 1 are one macro step while none of them reads a new input value
    // or opens the armature, and it ends at the end of the step that records the next sample
    // when the sample falls there, else before that step (whose start state the sampler
    // interpolates from, kept below).
    bool macro_taken = false;
    double macro_state[3];  // i, w, theta at the macro step's end
    advance = 1;
    if ((linear || (coulomb_macro && w != 0.0 && step >= single_steps_until)) && !open) {
      if (record_at != record_step_for) {
        record_step = first_step(record_at, false) - 1;  // the recording step's index
        record_step_for = record_at;
        const double step_start = t_start + static_cast<double>(record_step) * dt;
        const double step_end = t_start + static_cast<double>(record_step + 1) * dt;
        sample_on_step_end =
            (sampler.next_time() - step_start) / (step_end - step_start) > 1.0 - 1e-9;
      }
      if (input_next_change != change_step_for) {
        change_step = first_step(input_next_change, true);
        change_step_for = input_next_change;
      }
      const long last = sample_on_step_end ? record_step + 1 : record_step;
      const long n = std::min({last, change_step, coast_step}) - step;
      if (n >= 2) {
        const MacroStep& macro_step = macro->For(n);
        const double* P = macro_step.P.data();
        const double* G = macro_step.G.data();
        // T_effects as the single steps sum it: the load, plus the friction of w's sign.
        const double load = linear ? shaft.TL : (w > 0.0 ? shaft.Tc : -shaft.Tc) + shaft.TL;
        macro_state[0] = P[0] * i + P[1] * w + P[2] * theta + (G[0] * u + G[1] * load);
        macro_state[1] = P[3] * i + P[4] * w + P[5] * theta + (G[2] * u + G[3] * load);
        macro_state[2] = P[6] * i + P[7] * w + P[8] * theta + (G[4] * u + G[5] * load);
        bool keeps_sign = true;
        if (!linear) {
          // w after the first step and before the last (macro_step's data may be reused by
          // For below: macro_state is already computed).
          const double w_first = a10 * i + a11 * w + a12 * theta + (b10 * u + b11 * load);
          const MacroStep& but_one = macro->For(n - 1);
          const double w_before_last = but_one.P[3] * i + but_one.P[4] * w + but_one.P[5] * theta +
                                       (but_one.G[2] * u + but_one.G[3] * load);
          const double sign = w > 0.0 ? 1.0 : -1.0, w_last = macro_state[1];
          keeps_sign = sign * w_first > 0.0 && sign * w_before_last > 0.0 && sign * w_last > 0.0 &&
                       (w_first - w) * (w_last - w_before_last) >= 0.0;
        }
        if (!keeps_sign) {
          // w may reach zero inside the stretch: single steps, which stop or stick it.
          single_steps_until = step + n;
        } else if (internal::AllFinite(macro_state, 3, limit) &&
                   std::abs(macro_state[0] + drive.i0) <= limit) {
          macro_taken = true;
          advance = n;
        } else {
          // Diverging: single steps from here on, so the run ends at the first step past the
          // limit, as the reference does.
          linear = coulomb_macro = false;
        }
      }
    }
    const double t_next = t_start + static_cast<double>(step + advance) * dt;
    const double w_old = w, theta_old = theta;
    const double u_eff =
        drive.Vdt == 0.0 ? u : u - drive.Vdt * (i > 0.0 ? 1.0 : (i < 0.0 ? -1.0 : 0.0));
    if (macro_taken) {
      i = macro_state[0];
      w = macro_state[1];
      theta = macro_state[2];
    } else if (plain_shaft && !open) {
      // No friction, drag or cogging: T_effects = TL, one matrix step. The input terms do
      // not depend on the state, so they are off the step-to-step dependency chain; theta
      // does not feed i or w (a02 = a12 = 0, a22 = 1 exactly, checked), so the chain from
      // one step's state to the next is a multiply, a fused multiply-add and an add.
      const double load = shaft.TL;
      const double in0 = b00 * u_eff + b01 * load, in1 = b10 * u_eff + b11 * load,
                   in2 = b20 * u_eff + b21 * load;
      if (theta_decoupled) {
        const double i1 = (a00 * i + a01 * w) + in0;
        const double w1 = (a10 * i + a11 * w) + in1;
        theta += (a20 * i + a21 * w) + in2;
        i = i1;
        w = w1;
      } else {
        const double i1 = a00 * i + a01 * w + a02 * theta + in0;
        const double w1 = a10 * i + a11 * w + a12 * theta + in1;
        const double th1 = a20 * i + a21 * w + a22 * theta + in2;
        i = i1;
        w = w1;
        theta = th1;
      }
    } else {
      const double positional = shaft.NonFrictionTorque(theta);
      const double non_friction = positional + shaft.DragTorque(w);
      if (open) {
        i = 0.0;
        bool stuck = false;
        const double friction = shaft.StepFriction(w, -non_friction, &stuck);
        if (!stuck) {
          const double torque = friction + non_friction;
          const double w1 = open_a00 * w + open_a01 * theta + open_b0 * torque;
          const double th1 = open_a10 * w + open_a11 * theta + open_b1 * torque;
          w = w1;
          theta = th1;
        }
      } else {
        bool stuck = false;
        const double friction = shaft.StepFriction(w, Kt * i - non_friction, &stuck);
        if (stuck) {
          i = stuck_a * i + stuck_b * u_eff;
        } else {
          const double torque = friction + non_friction;
          const double i1 = a00 * i + a01 * w + a02 * theta + (b00 * u_eff + b01 * torque);
          const double w1 = a10 * i + a11 * w + a12 * theta + (b10 * u_eff + b11 * torque);
          const double th1 = a20 * i + a21 * w + a22 * theta + (b20 * u_eff + b21 * torque);
          i = i1;
          w = w1;
          theta = th1;
        }
      }
      shaft.StopInStep(w_old, theta_old, dt, J, B, Kt * i - positional, &w, &theta);
    }

    u = control(t_next, &reference);
    const double i_out = i + drive.i0;
    if (!(std::abs(i_out) <= limit && std::abs(w) <= limit && std::abs(theta) <= limit)) {
      return {SimStatus::Code::kDiverged, internal::DivergedMessage(limit), t_next};
    }
    if (t_next >= record_at) {
      now[0] = u;
      now[1] = i_out;
      now[2] = w;
      now[3] = theta;
      now[4] = reference;
      // The recording step's start (t itself after a single step; after a macro step that
      // ends on the sample, prev is not read: the sample is at the step's end).
      sampler.Record(t_start + static_cast<double>(step + advance - 1) * dt, prev, t_next, now);
      record_at = next_record_time();
    }
    // The state before the step that records (after a macro step always: it may end there).
    if (advance > 1 || t_next + dt >= record_at) {
      prev[0] = u;
      prev[1] = i_out;
      prev[2] = w;
      prev[3] = theta;
      prev[4] = reference;
    }
  }
  sampler.Finish(out);
  if (!closed_loop) {
    auto& u_column = out->Column("u");
    InputCursor u_cursor(experiment.input);  // sample times increase: no search per sample
    for (std::size_t k = 0; k < times.size(); ++k) u_column[k] = u_cursor.At(times[k]);
  }
  return SimStatus::Ok();
}

}  // namespace blmd
