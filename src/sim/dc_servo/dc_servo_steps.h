// Private helpers of the dc_servo model's steps (src/sim/dc_servo/dc_servo.cc;
// docs/model-dc-servo.md). The fast path (dc_servo_fast.cc) computes the same quantities in its own
// Simulate: split into these and its own steps, it ran the closed loop ~5 % slower
// (docs/architecture.md §6).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "blmd/sim/effects.h"
#include "blmd/sim/experiment.h"
#include "blmd/sim/model.h"
#include "blmd/sim/parameters.h"
#include "sim/discretise.h"
#include "sim/input_read.h"
#include "sim/sampler.h"

namespace blmd::internal {

// The exact discretisations (discretise.h) of the model's three configurations at step dt:
//   full system:        x = [i, w, theta], inputs [u_eff, T_effects]  (Ad, Bd);
//   shaft stuck (w = 0): x = [i], input u_eff                          (Ads, Bds);
//   armature open (i = 0): x = [w, theta], input T_effects             (Ado, Bdo).
struct DcServoDiscretisation {
  Eigen::Matrix3d Ad;
  Eigen::Matrix<double, 3, 2> Bd;
  Eigen::Matrix<double, 1, 1> Ads, Bds;
  Eigen::Matrix2d Ado;
  Eigen::Matrix<double, 2, 1> Bdo;

  static DcServoDiscretisation From(const ParameterSet& values, double dt) {
    const double R = values.Get("R"), L = values.Get("L"), Kt = values.Get("Kt"),
                 Kb = values.Get("Kb"), J = values.Get("J"), B = values.Get("B");
    DcServoDiscretisation d;
    Eigen::Matrix3d A;
    A << -R / L, -Kb / L, 0.0, Kt / J, -B / J, 0.0, 0.0, 1.0, 0.0;
    Eigen::Matrix<double, 3, 2> Bm;
    Bm << 1.0 / L, 0.0, 0.0, -1.0 / J, 0.0, 0.0;
    Discretise<3, 2>(A, Bm, dt, &d.Ad, &d.Bd);
    Eigen::Matrix<double, 1, 1> As, Bs;
    As << -R / L;
    Bs << 1.0 / L;
    Discretise<1, 1>(As, Bs, dt, &d.Ads, &d.Bds);
    Eigen::Matrix2d Ao;
    Eigen::Matrix<double, 2, 1> Bo;
    Ao << -B / J, 0.0, 1.0, 0.0;
    Bo << -1.0 / J, 0.0;
    Discretise<2, 1>(Ao, Bo, dt, &d.Ado, &d.Bdo);
    return d;
  }
};

// The position PID of a closed-loop experiment (docs/model-dc-servo.md): a first-order
// filtered derivative of the measured angle (backward Euler, alpha = dt / (tau_d + dt)) and
// conditional integration (the integrator holds while the output saturates in the direction
// of the error).
struct DcServoPid {
  double integral = 0.0;
  double derivative_state = 0.0;  // rad (speed loop: rad/s), the filtered y of the D term

  // The voltage over the next step for the reference r and the measured y (the angle theta,
  // or the speed w for the speed loop).
  [[gnu::always_inline]] inline double Control(const PidSettings& pid, double alpha, double dt,
                                               double r, double y) {
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
  }
};

// The same PID as a drive's digital controller (pid.sample_rate > 0, docs/model-dc-servo.md
// §6.1): it samples r and y every `every` simulation steps (period Ts = every dt, its
// derivative filter and integral on Ts), and its output takes effect `pid.delay` samples
// later and is held between samples (zero-order hold); before its first output takes effect
// the drive applies 0 V. With sample_rate 0 it is DcServoPid on every step, without delay.
class SampledDcServoPid {
 public:
  SampledDcServoPid(const PidSettings& pid, double dt, double y0) : pid_(pid), dt_(dt) {
    state_.derivative_state = y0;
    if (pid.sample_rate > 0.0) {
      every_ = std::max(1L, std::lround(1.0 / (pid.sample_rate * dt)));
      pending_.assign(static_cast<std::size_t>(pid.delay) + 1, 0.0);
    }
    const double period = every_ > 0 ? static_cast<double>(every_) * dt : dt;
    alpha_ = period / (pid.tau_d + period);
  }

  // The voltage over the step that starts now, for the reference r and the measured y.
  double Step(double r, double y) {
    if (every_ == 0) return state_.Control(pid_, alpha_, dt_, r, y);
    if (countdown_ == 0) {
      countdown_ = every_;
      // pending_ is a ring of delay + 1 outputs: the slot written now is read delay samples on.
      pending_[next_] = state_.Control(pid_, alpha_, static_cast<double>(every_) * dt_, r, y);
      next_ = (next_ + 1) % pending_.size();
      held_ = pending_[next_];
    }
    --countdown_;
    return held_;
  }

 private:
  const PidSettings& pid_;
  double dt_, alpha_ = 0.0;
  DcServoPid state_;
  long every_ = 0, countdown_ = 0;  // every_ 0: every step, no delay
  std::vector<double> pending_;
  std::size_t next_ = 0;
  double held_ = 0.0;
};

// The reference paths' step loop (the rigid shaft, dc_servo.cc, and the two-mass shaft,
// dc_servo_two_mass.cc): `advance(t, open, u_eff, &i, &w, &theta)` moves the state over
// [t, t + dt) under the voltage u_eff (the armature open when `open`) and returns false when a
// state it keeps itself (the load's) diverged. The input over a step is read just after its
// midpoint (sim/input_read.h), so that an event on the step grid (a step's t0, an `open`
// sample, coast_off_time) takes effect at that grid point whatever the rounding of
// t = t_start + k dt; an event between grid points takes effect at the nearest one, one on a
// midpoint at the earlier one. The PID runs at t with the state at t. Each sample records the
// state at t_next with the voltage applied from t_next on, so that the u column of a
// closed-loop trace means what it means in open loop and replays as a recorded input; an
// open-loop trace's u is the input at the sample times. `load` (two_mass): the load's speed
// and angle, which `advance` keeps current, written as the columns w_load and theta_load.
template <typename Advance>
SimStatus RunDcServoSteps(const SimulationRequest& request, const DriveEffects& drive,
                          Advance advance, Trace* out,
                          const std::array<double, 2>* load = nullptr) {
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  const bool closed_loop = experiment.closed_loop;
  const bool has_coast = experiment.coast_off_time >= 0.0;
  std::vector<std::string> names = {"u", "i", "w", "theta"};
  if (closed_loop) names.emplace_back("r");
  if (load) names.insert(names.end(), {"w_load", "theta_load"});
  OutputSampler sampler(times, names);
  InputCursor input(experiment.input);
  const double t_start = times.front();
  double i = experiment.initial.i, w = experiment.initial.w, theta = experiment.initial.theta;
  const bool speed_loop = experiment.pid.loop == PidSettings::Loop::kSpeed;
  SampledDcServoPid pid(experiment.pid, dt, speed_loop ? w : theta);
  auto control = [&](double t, double* reference) {
    const double r = input.At(InputReadTime(t, dt));
    *reference = r;
    return closed_loop ? pid.Step(r, speed_loop ? w : theta) : r;
  };
  double reference = 0.0;
  double u = control(t_start, &reference);
  // The recorded row: u, i, w, theta, then r (closed loop) and the load's columns.
  auto row = [&]() {
    std::array<double, 7> values = {u, i + drive.i0, w, theta, reference, 0.0, 0.0};
    if (load) {
      const std::size_t at = closed_loop ? 5 : 4;
      values[at] = (*load)[0];
      values[at + 1] = (*load)[1];
    }
    return values;
  };
  std::array<double, 7> prev = row();
  sampler.Record(t_start, prev.data(), t_start, prev.data());
  std::array<double, 7> now = prev;
  for (long step = 0; !sampler.done(); ++step) {
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_next = t_start + static_cast<double>(step + 1) * dt;
    const double t_mid = InputReadTime(t, dt);
    const bool open = (has_coast && t_mid >= experiment.coast_off_time) || input.OpenAt(t_mid);
    const double u_eff = u - drive.Vdt * (i > 0.0 ? 1.0 : (i < 0.0 ? -1.0 : 0.0));
    const bool own_finite = advance(t, open, u_eff, &i, &w, &theta);
    u = control(t_next, &reference);
    now = row();
    if (!own_finite || !AllFinite(now.data() + 1, 3, request.settings.divergence_limit)) {
      return {SimStatus::Code::kDiverged, DivergedMessage(request.settings.divergence_limit),
              t_next};
    }
    sampler.Record(t, prev.data(), t_next, now.data());
    prev = now;
  }
  sampler.Finish(out);
  if (!closed_loop) {
    auto& u_column = out->Column("u");
    // (a cursor: the sample times increase, so each read continues where the last stopped)
    InputCursor u_cursor(experiment.input);
    for (std::size_t k = 0; k < times.size(); ++k) u_column[k] = u_cursor.At(times[k]);
  }
  return SimStatus::Ok();
}

}  // namespace blmd::internal
