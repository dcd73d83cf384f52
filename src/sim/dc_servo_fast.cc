// The dc_servo model's fast path: SimulateReference (dc_servo.cc) with the exact
// discretisation's matrices unrolled into scalars, the input read again only when it can
// change (InputCursor::NextChange), and outputs written only at the sample steps
// (docs/performance.md). No allocation, virtual call or look-up inside the step loop.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "blmd/sim/dc_servo.h"
#include "blmd/sim/effects.h"
#include "sim/discretise.h"
#include "sim/sampler.h"

namespace blmd {

SimStatus DcServoModel::Simulate(const SimulationRequest& request, Trace* out) const {
  if (internal::ForcedEffectAngle(request.settings)) return SimulateReference(request, out);
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  if (std::string error = Validate(values, request.settings); !error.empty()) {
    return {SimStatus::Code::kInvalidParameters, error, 0.0};
  }
  if (times.empty()) return {SimStatus::Code::kInvalidParameters, "no sample times", 0.0};

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
  const bool plain_shaft = !shaft.has_friction() && shaft.Tcog == 0.0 && shaft.Cd == 0.0;

  const bool closed_loop = experiment.closed_loop;
  const PidSettings& pid = experiment.pid;
  const bool has_coast = experiment.coast_off_time >= 0.0;

  std::vector<std::string> names = {"u", "i", "w", "theta"};
  if (closed_loop) names.push_back("r");
  internal::OutputSampler sampler(times, names);

  InputCursor input(experiment.input);
  const double t_start = times.front();
  double i = experiment.initial.i, w = experiment.initial.w, theta = experiment.initial.theta;
  double integral = 0.0, derivative_state = theta;
  const double alpha = dt / (pid.tau_d + dt);

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
    read_input(t + 0.5 * dt);
    const double r = input_value;
    *reference = r;
    if (!closed_loop) return r;
    const double error = r - theta;
    const double filtered_prev = derivative_state;
    derivative_state += alpha * (theta - derivative_state);
    const double dtheta = (derivative_state - filtered_prev) / dt;
    double u = pid.Kp * error + pid.Ki * integral - pid.Kd * dtheta;
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

  for (long step = 0; !sampler.done(); ++step) {
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_next = t_start + static_cast<double>(step + 1) * dt;
    const double t_mid = t + 0.5 * dt;
    // The open flag is read at t_mid; control() already read the input there.
    const bool open = (has_coast && t_mid >= experiment.coast_off_time) || input_open;
    const double w_old = w, theta_old = theta;
    const double u_eff =
        drive.Vdt == 0.0 ? u : u - drive.Vdt * (i > 0.0 ? 1.0 : (i < 0.0 ? -1.0 : 0.0));
    if (plain_shaft && !open) {
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
      const double non_friction = shaft.NonFrictionTorque(theta) + shaft.DragTorque(w);
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
      if (shaft.StopsWithin(w_old, w)) {
        const double fraction = w_old / (w_old - w);
        theta = theta_old + 0.5 * w_old * fraction * dt;
        w = 0.0;
      }
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
      sampler.Record(t, prev, t_next, now);
      record_at = next_record_time();
    }
    if (t_next + dt >= record_at) {
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
    for (std::size_t k = 0; k < times.size(); ++k) u_column[k] = experiment.input.At(times[k]);
  }
  return SimStatus::Ok();
}

}  // namespace blmd
