// The blmd model's fast path: the equations and step of SimulateReference (blmd_drive.cc,
// docs/model-blmd.md §5), arranged for speed (docs/performance.md):
// - the electrical angle's cosine and sine are advanced by rotation through the step's
//   angle change p (theta_H - theta_L) (a short Taylor series), and resynchronised with
//   std::cos/std::sin of p theta every kResyncSteps steps and after a friction stop;
// - a leg whose command has not changed within the blanking time and does not cross the
//   carrier inside the step is at Ud or 0 for the whole step (the usual case, ~95 % of leg
//   steps): the edge and blanking arithmetic runs only on the others;
// - the leg solver (diodes, open phases) runs only when a leg has a both-off interval;
// - the demand is read again only when it can change (InputCursor::NextChange);
// - outputs are written only at the steps that end on or past a sample time;
// - no allocation, virtual call, map look-up or string inside the step loop.
#include <algorithm>
#include <cmath>

#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/effects.h"
#include "sim/blmd/blmd_events.h"
#include "sim/blmd/blmd_legs.h"
#include "sim/input_read.h"
#include "sim/plain_shaft.h"
#include "sim/sampler.h"

namespace blmd {
namespace {

constexpr int kResyncSteps = 256;

struct FastLeg {
  bool upper_commanded = false;
  double t_edge = -1.0;     // s
  double settled_at = 0.0;  // s, t_edge + delta: from here on the commanded switch conducts
};

// A leg's step with an edge or inside its blanking time (the reference's arithmetic).
[[gnu::noinline]] void EdgeStep(FastLeg* leg, double t_low, double t_high, double dt, double inv_dt,
                                double d_low, double d_high, bool regula_falsi, double delta,
                                double Ud, double* switched, double* off) {
  if ((d_low < 0.0) != leg->upper_commanded) {
    leg->upper_commanded = d_low < 0.0;
    leg->t_edge = t_low;
    leg->settled_at = t_low + delta;
  }
  double upper_on = 0.0, off_time = 0.0;
  auto conduct = [&](double a, double b) {
    if (leg->upper_commanded) upper_on += internal::ConductingTime(a, b, leg->t_edge, delta);
    off_time += std::max(0.0, std::min(b, leg->settled_at) - a);
  };
  if (regula_falsi && (d_high < 0.0) != leg->upper_commanded) {
    const double t_cross = t_low + dt * d_low / (d_low - d_high);
    conduct(t_low, t_cross);
    leg->upper_commanded = d_high < 0.0;
    leg->t_edge = t_cross;
    leg->settled_at = t_cross + delta;
    conduct(t_cross, t_high);
  } else {
    conduct(t_low, t_high);
  }
  *switched = Ud * upper_on * inv_dt;
  *off = off_time * inv_dt;
}

// The step loop, compiled for AVX2 (three-operand VEX encoding, no fused multiply-adds) and
// for the x86-64 baseline, the CPU picking the clone at load time.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
[[gnu::target_clones("avx2", "default")]]
#endif
SimStatus
SimulateFast(const BlmdDriveModel& model, const SimulationRequest& request, Trace* out) {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const SimulationSettings& settings = request.settings;
  const double dt = settings.dt;
  if (SimStatus status = model.CheckRequest(request); !status.ok()) return status;

  const internal::BlmdStepConstants k =
      internal::BlmdStepConstants::From(values, *request.effects, settings);
  const double Ud = k.Ud, Ke = k.Ke, p = k.p, Kc = k.Kc, Kf = k.Kf, Kp = k.Kp, Vtri = k.Vtri,
               delta = k.delta;
  const ShaftEffects shaft = k.shaft;
  const DriveEffects drive = k.drive;
  const bool regula_falsi = settings.regula_falsi, diagnostics = settings.diagnostics;
  const double limit = settings.divergence_limit;

  const double current_gain = k.current_gain, speed_gain = k.speed_gain, lag_norm = k.lag_norm;
  const double Tp_dt = k.Tp_dt, lead_gain = k.lead_gain, Tz_dt = k.Tz_dt, Ki_dt = k.Ki_dt;
  const bool lead_lag = k.lead_lag;
  const double dt_Ls = k.dt_Ls, Ls_dt = k.Ls_dt, dt_J = k.dt_J, inv_dt = 1.0 / dt;
  // No friction, drag or cogging: the shaft's step is the drive torque less B w and TL.
  const bool plain_shaft = internal::PlainShaft(shaft);

  const long steps_per_half_period = k.steps_per_half_period;
  const double carrier_slope = k.carrier_slope;
  auto carrier_at = [&](long index_in_period) {
    return index_in_period <= steps_per_half_period
               ? -Vtri + carrier_slope * static_cast<double>(index_in_period)
               : Vtri -
                     carrier_slope * static_cast<double>(index_in_period - steps_per_half_period);
  };

  internal::OutputSampler sampler(times, internal::BlmdOutputNames(diagnostics));
  InputCursor input(experiment.input);

  const double t_start = times.front();
  double current[3] = {0.0, 0.0, 0.0};
  double w = experiment.initial.w, theta = experiment.initial.theta;
  double integral[3] = {0.0, 0.0, 0.0}, lead_out[3] = {0.0, 0.0, 0.0};
  double error_prev[3] = {0.0, 0.0, 0.0};
  FastLeg legs[3];
  double phase_voltage[3] = {0.0, 0.0, 0.0};
  double torque = 0.0, neutral_voltage = 0.0;

  auto pack = [&](double* row) {
    row[0] = 0.0;  // u: written after the run
    row[1] = current[0] + drive.i0;
    row[2] = current[1];
    row[3] = current[2];
    row[4] = w;
    row[5] = theta;
    if (diagnostics) {
      row[6] = phase_voltage[0];
      row[7] = phase_voltage[1];
      row[8] = phase_voltage[2];
      row[9] = torque;
      row[10] = neutral_voltage;
    }
  };
  double prev[11] = {}, now[11] = {};
  pack(prev);
  sampler.Record(t_start, prev, t_start, prev);
  // The step ending at or past this time records a sample (the sampler's own test).
  auto next_record_time = [&] { return sampler.done() ? 1e300 : sampler.next_time() - 1e-9 * dt; };
  double record_at = next_record_time();

  constexpr double kHalfSqrt3 = 0.86602540378443864676;
  double cos_a = std::cos(p * theta), sin_a = std::sin(p * theta);
  int until_resync = kResyncSteps;
  double demand = 0.0, demand_next_change = -1e300;
  long index_in_period = 0;
  bool first_step = true;
  double t_high = t_start;      // the previous step's end: this step's start, the same double
  double carrier_high = -Vtri;  // carrier_at(0)
  for (long step = 0; !sampler.done(); ++step) {
    const double t_low = t_high;
    t_high = t_start + static_cast<double>(step + 1) * dt;
    const double t_mid = internal::InputReadTime(t_low, dt);
    if (t_mid >= demand_next_change) {  // read again only when the signal can change
      demand = input.At(t_mid);
      demand_next_change = input.NextChange(t_mid);
    }
    const double cosine[3] = {cos_a, -0.5 * cos_a + kHalfSqrt3 * sin_a,
                              -0.5 * cos_a - kHalfSqrt3 * sin_a};

    const double carrier_low = carrier_high;  // carrier_at(index_in_period), last step's end
    carrier_high = carrier_at(index_in_period + 1);
    if (++index_in_period == 2 * steps_per_half_period) index_in_period = 0;
    const double full_on = Ud * (t_high - t_low) * inv_dt;  // a switch on for the whole step
    double switched[3], off[3];
    bool any_off = false;
    const double demand_current = Kc * demand;
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      const double error = demand_current * cosine[j] - Kf * current[j];
      if (lead_lag) {
        lead_out[j] =
            lag_norm * (Tp_dt * lead_out[j] + Kp * (lead_gain * error - Tz_dt * error_prev[j]));
        error_prev[j] = error;
      } else {
        lead_out[j] = Kp * error;  // the same value: lag_norm = lead_gain = 1, Tp_dt = Tz_dt = 0
      }
      const double proposed_integral = integral[j] + Ki_dt * error;
      const double unclamped = lead_out[j] + proposed_integral;
      if (std::abs(unclamped) <= Vtri || unclamped * error < 0.0) integral[j] = proposed_integral;
      const double control = std::clamp(lead_out[j] + integral[j], -Vtri, Vtri);

      FastLeg& leg = legs[j];
      const double d_low = carrier_low - control;
      const double d_high = carrier_high - control;
      if (first_step) [[unlikely]] {
        leg.upper_commanded = d_low < 0.0;
        leg.t_edge = t_low - 2.0 * delta - dt;
        leg.settled_at = leg.t_edge + delta;
      }
      const bool upper_now = d_low < 0.0;
      if (upper_now == leg.upper_commanded && (d_high < 0.0) == upper_now &&
          leg.settled_at <= t_low) {  // no edge, settled for the whole step (the usual case)
        switched[j] = leg.upper_commanded ? full_on : 0.0;  // state, not this step's compare
        off[j] = 0.0;
        continue;
      }
      EdgeStep(&leg, t_low, t_high, dt, inv_dt, d_low, d_high, regula_falsi, delta, Ud,
               &switched[j], &off[j]);
      any_off = any_off || off[j] > 0.0;
    }
    first_step = false;

    double leg_voltage[3] = {switched[0], switched[1], switched[2]};
    bool open[3] = {false, false, false};
    if (any_off) {
      // A current farther from zero than one step can move it keeps its sign to the step's
      // end, so its diode is known (the solver's first guess, which it would accept); the
      // solver runs only when some blanked phase is near zero current.
      const double reach = dt_Ls * (Ud + std::abs(Ke * w)) + 1e-12;
      bool near_zero = false;
      for (int j = 0; j < 3; ++j) {
        if (off[j] > 0.0) near_zero = near_zero || !(std::abs(current[j]) > reach);
      }
      if (near_zero) {
        double hold[3];
        for (int j = 0; j < 3; ++j) hold[j] = Ke * w * cosine[j] - Ls_dt * current[j];
        internal::LegSolver::Solve(switched, off, hold, current, Ud, leg_voltage, open);
      } else {
        for (int j = 0; j < 3; ++j) {
          if (off[j] > 0.0 && current[j] < 0.0) leg_voltage[j] = switched[j] + Ud * off[j];
        }
      }
    }
    neutral_voltage =
        (leg_voltage[0] + leg_voltage[1] + leg_voltage[2]) / 3.0;  // exact for equal legs

    torque = 0.0;
    const double emf_w = Ke * w;
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      phase_voltage[j] = leg_voltage[j] - neutral_voltage;
      const double emf = emf_w * cosine[j];
      current[j] = open[j] ? 0.0 : (current[j] + dt_Ls * (phase_voltage[j] - emf)) * current_gain;
      torque += Ke * current[j] * cosine[j];
    }

    const double w_old = w, theta_old = theta;
    bool resync = --until_resync == 0;
    if (plain_shaft) {
      w = (w + dt_J * (torque - shaft.TL)) * speed_gain;
      theta += dt * w;
    } else {
      const double non_friction = shaft.NonFrictionTorque(theta) + shaft.DragTorque(w);
      bool stuck = false;
      const double friction = shaft.StepFriction(w, torque - non_friction, &stuck);
      if (!stuck) {
        w = (w + dt_J * (torque - friction - non_friction)) * speed_gain;
        if (shaft.StopsWithin(w_old, w)) {
          const double fraction = w_old / (w_old - w);
          w = 0.0;
          theta = theta_old + 0.5 * w_old * fraction * dt;
          resync = true;
        } else {
          theta += dt * w;
        }
      }
    }
    // Electrical angle: rotate by x = p (theta_H - theta_L) (exact difference of the two
    // doubles), cos x and sin x by their Taylor series (error below x^7/5040 < 2e-18 for
    // |x| < 0.01); larger steps and every kResyncSteps steps take std::cos/std::sin.
    const double x = p * (theta - theta_old);
    if (resync || !(std::abs(x) < 0.01)) {
      cos_a = std::cos(p * theta);
      sin_a = std::sin(p * theta);
      until_resync = kResyncSteps;
    } else {
      const double x2 = x * x;
      const double cos_x = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0)));
      const double sin_x = x * (1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0)));
      const double c = cos_a * cos_x - sin_a * sin_x;
      sin_a = sin_a * cos_x + cos_a * sin_x;
      cos_a = c;
    }

    const double ia = current[0] + drive.i0;
    if (!(std::abs(ia) <= limit && std::abs(current[1]) <= limit && std::abs(current[2]) <= limit &&
          std::abs(w) <= limit && std::abs(theta) <= limit)) {
      return {SimStatus::Code::kDiverged, internal::DivergedMessage(limit), t_high};
    }
    if (t_high >= record_at) {
      pack(now);
      sampler.Record(t_low, prev, t_high, now);
      record_at = next_record_time();
    }
    // The state at this step's end is the next step's start, kept for the sampler's
    // interpolation of a sample that falls inside a step.
    if (t_high + dt >= record_at) pack(prev);
  }
  sampler.Finish(out);
  auto& u_column = out->Column("u");
  InputCursor u_cursor(experiment.input);  // sample times increase: no search per sample
  for (std::size_t k = 0; k < times.size(); ++k)
    u_column[k] = u_cursor.At(internal::InputReadTime(times[k], dt));
  return SimStatus::Ok();
}

}  // namespace

SimStatus BlmdDriveModel::Simulate(const SimulationRequest& request, Trace* out) const {
  // The closed loop (experiment.pid) runs on the reference step loop whatever the method: the
  // controller's samples fall on its grid (docs/model-blmd.md §10).
  if (request.experiment->closed_loop) return SimulateReference(request, out);
  // A two-mass shaft (docs/effects.md) runs on the reference step loop whatever the method:
  // its exact four-state step replaces the rigid shaft's there (docs/model-blmd.md §10a).
  if (ShaftEffects::From(*request.parameters, *request.effects, 0.0).two_mass()) {
    return SimulateReference(request, out);
  }
  if (request.settings.method == SimulationMethod::kEvents) {
    return internal::SimulateBlmdEvents(*this, request, out);
  }
  if (internal::ForcedEffectAngle(request.settings)) return SimulateReference(request, out);
  return SimulateFast(*this, request, out);
}

}  // namespace blmd
