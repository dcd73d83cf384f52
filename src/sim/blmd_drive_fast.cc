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

#include "blmd/sim/blmd_drive.h"
#include "blmd/sim/effects.h"
#include "sim/blmd_legs.h"
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

#define BLMD_STEP_INLINE [[gnu::always_inline]] inline

// The carrier at a step boundary, index_in_period in [0, 2N]: -Vtri at the run's start,
// +Vtri after Tpwm/2 (N steps), linear in between.
BLMD_STEP_INLINE double CarrierAt(const internal::BlmdStepConstants& k, long index_in_period) {
  return index_in_period <= k.steps_per_half_period
             ? -k.Vtri + k.carrier_slope * static_cast<double>(index_in_period)
             : k.Vtri -
                   k.carrier_slope * static_cast<double>(index_in_period - k.steps_per_half_period);
}

// The three phases' current compensators: a PI, or with Tz or Tp a lead-lag part before the
// integrator (the reference's arithmetic with the constants of BlmdStepConstants).
struct Compensators {
  double integral[3] = {0.0, 0.0, 0.0};    // V
  double lead_out[3] = {0.0, 0.0, 0.0};    // V
  double error_prev[3] = {0.0, 0.0, 0.0};  // V
};

// The compensator of phase j, from its current error: the control voltage in [-Vtri, Vtri].
BLMD_STEP_INLINE double Compensate(const internal::BlmdStepConstants& k, int j, double error,
                                   Compensators* c) {
  if (k.lead_lag) {
    c->lead_out[j] = k.lag_norm * (k.Tp_dt * c->lead_out[j] +
                                   k.Kp * (k.lead_gain * error - k.Tz_dt * c->error_prev[j]));
    c->error_prev[j] = error;
  } else {
    c->lead_out[j] = k.Kp * error;  // the same value: lag_norm = lead_gain = 1, Tp_dt = Tz_dt = 0
  }
  const double proposed_integral = c->integral[j] + k.Ki_dt * error;
  const double unclamped = c->lead_out[j] + proposed_integral;
  if (std::abs(unclamped) <= k.Vtri || unclamped * error < 0.0) c->integral[j] = proposed_integral;
  return std::clamp(c->lead_out[j] + c->integral[j], -k.Vtri, k.Vtri);
}

// One step [t_low, t_high] of the compensators and the PWM legs: each phase's switched
// voltage and both-off time (in steps). Returns whether some leg has a both-off interval.
BLMD_STEP_INLINE bool CompensateAndSwitch(const internal::BlmdStepConstants& k, bool regula_falsi,
                                          bool first_step, double t_low, double t_high, double dt,
                                          double inv_dt, double carrier_low, double carrier_high,
                                          double demand, const double cosine[3],
                                          const double current[3], Compensators* compensators,
                                          FastLeg legs[3], double switched[3], double off[3]) {
  const double full_on = k.Ud * (t_high - t_low) * inv_dt;  // a switch on for the whole step
  bool any_off = false;
  const double demand_current = k.Kc * demand;
#pragma GCC unroll 3
  for (int j = 0; j < 3; ++j) {
    const double error = demand_current * cosine[j] - k.Kf * current[j];
    const double control = Compensate(k, j, error, compensators);
    FastLeg& leg = legs[j];
    const double d_low = carrier_low - control;
    const double d_high = carrier_high - control;
    if (first_step) [[unlikely]] {
      leg.upper_commanded = d_low < 0.0;
      leg.t_edge = t_low - 2.0 * k.delta - dt;
      leg.settled_at = leg.t_edge + k.delta;
    }
    const bool upper_now = d_low < 0.0;
    if (upper_now == leg.upper_commanded && (d_high < 0.0) == upper_now &&
        leg.settled_at <= t_low) {  // no edge, settled for the whole step (the usual case)
      switched[j] = leg.upper_commanded ? full_on : 0.0;  // state, not this step's compare
      off[j] = 0.0;
      continue;
    }
    EdgeStep(&leg, t_low, t_high, dt, inv_dt, d_low, d_high, regula_falsi, k.delta, k.Ud,
             &switched[j], &off[j]);
    any_off = any_off || off[j] > 0.0;
  }
  return any_off;
}

// The leg voltages when some leg has a both-off interval: the diodes and open phases. A
// current farther from zero than one step can move it keeps its sign to the step's end, so
// its diode is known (the solver's first guess, which it would accept); the solver runs only
// when some blanked phase is near zero current.
BLMD_STEP_INLINE void BlankedLegVoltages(const internal::BlmdStepConstants& k, double w,
                                         const double cosine[3], const double current[3],
                                         const double switched[3], const double off[3],
                                         double leg_voltage[3], bool open[3]) {
  const double reach = k.dt_Ls * (k.Ud + std::abs(k.Ke * w)) + 1e-12;
  bool near_zero = false;
  for (int j = 0; j < 3; ++j) {
    if (off[j] > 0.0) near_zero = near_zero || !(std::abs(current[j]) > reach);
  }
  if (near_zero) {
    double hold[3];
    for (int j = 0; j < 3; ++j) hold[j] = k.Ke * w * cosine[j] - k.Ls_dt * current[j];
    internal::LegSolver::Solve(switched, off, hold, current, k.Ud, leg_voltage, open);
  } else {
    for (int j = 0; j < 3; ++j) {
      if (off[j] > 0.0 && current[j] < 0.0) leg_voltage[j] = switched[j] + k.Ud * off[j];
    }
  }
}

// The windings over the step (backward Euler, back-EMF from the step-start speed and angle):
// the phase voltages, the currents at the step's end and the torque. Returns the torque.
BLMD_STEP_INLINE double StepWindings(const internal::BlmdStepConstants& k, double w,
                                     const double cosine[3], const double leg_voltage[3],
                                     const bool open[3], double neutral_voltage,
                                     double phase_voltage[3], double current[3]) {
  double torque = 0.0;
  const double emf_w = k.Ke * w;
#pragma GCC unroll 3
  for (int j = 0; j < 3; ++j) {
    phase_voltage[j] = leg_voltage[j] - neutral_voltage;
    const double emf = emf_w * cosine[j];
    current[j] = open[j] ? 0.0 : (current[j] + k.dt_Ls * (phase_voltage[j] - emf)) * k.current_gain;
    torque += k.Ke * current[j] * cosine[j];
  }
  return torque;
}

// The shaft over the step (backward Euler) under the drive torque. Returns true when
// friction stopped it inside the step (the electrical angle is then resynchronised).
BLMD_STEP_INLINE bool StepShaft(const internal::BlmdStepConstants& k, bool plain_shaft, double dt,
                                double torque, double* w_io, double* theta_io) {
  double& w = *w_io;
  double& theta = *theta_io;
  const double w_old = w, theta_old = theta;
  if (plain_shaft) {  // no friction, drag or cogging: the drive torque less B w and TL
    w = (w + k.dt_J * (torque - k.shaft.TL)) * k.speed_gain;
    theta += dt * w;
    return false;
  }
  const ShaftEffects& shaft = k.shaft;
  const double non_friction = shaft.NonFrictionTorque(theta) + shaft.DragTorque(w);
  bool stuck = false;
  const double friction = shaft.StepFriction(w, torque - non_friction, &stuck);
  if (stuck) return false;
  w = (w + k.dt_J * (torque - friction - non_friction)) * k.speed_gain;
  if (shaft.StopsWithin(w_old, w)) {
    const double fraction = w_old / (w_old - w);
    w = 0.0;
    theta = theta_old + 0.5 * w_old * fraction * dt;
    return true;
  }
  theta += dt * w;
  return false;
}

// The electrical angle's cosine and sine after the shaft turned from theta_old to theta:
// rotated by x = p (theta - theta_old) (exact difference of the two doubles), cos x and sin x
// by their Taylor series (error below x^7/5040 < 2e-18 for |x| < 0.01); larger steps and a
// resynchronisation (every kResyncSteps steps, after a stop) take std::cos/std::sin.
BLMD_STEP_INLINE void AdvanceElectricalAngle(double p, double theta_old, double theta, bool resync,
                                             double* cos_a, double* sin_a, int* until_resync) {
  const double x = p * (theta - theta_old);
  if (resync || !(std::abs(x) < 0.01)) {
    *cos_a = std::cos(p * theta);
    *sin_a = std::sin(p * theta);
    *until_resync = kResyncSteps;
  } else {
    const double x2 = x * x;
    const double cos_x = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0)));
    const double sin_x = x * (1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0)));
    const double c = *cos_a * cos_x - *sin_a * sin_x;
    *sin_a = *sin_a * cos_x + *cos_a * sin_x;
    *cos_a = c;
  }
}

// The output row: u (written after the run), the currents (ia as measured, with i0), w,
// theta, and with diagnostics the phase voltages, torque and neutral voltage.
BLMD_STEP_INLINE void PackRow(bool diagnostics, double i0, const double current[3], double w,
                              double theta, const double phase_voltage[3], double torque,
                              double neutral_voltage, double* row) {
  row[0] = 0.0;
  row[1] = current[0] + i0;
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
}

// u at the sample times: the demand applied from that instant on, read as the steps read it
// (sample times increase: no search per sample).
void WriteDemandColumn(const Experiment& experiment, const std::vector<double>& times, double dt,
                       Trace* out) {
  auto& u_column = out->Column("u");
  InputCursor u_cursor(experiment.input);
  for (std::size_t k = 0; k < times.size(); ++k) u_column[k] = u_cursor.At(times[k] + 0.5 * dt);
}

// The step loop, compiled for AVX2 (three-operand VEX encoding, no fused multiply-adds) and
// for the x86-64 baseline, the CPU picking the clone at load time; the steps above are
// inlined into each clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
[[gnu::target_clones("avx2", "default")]]
#endif
SimStatus
SimulateFast(const BlmdDriveModel& model, const SimulationRequest& request, Trace* out) {
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const SimulationSettings& settings = request.settings;
  const double dt = settings.dt, inv_dt = 1.0 / dt;
  if (SimStatus status = model.CheckRequest(request); !status.ok()) return status;

  const internal::BlmdStepConstants k =
      internal::BlmdStepConstants::From(*request.parameters, *request.effects, settings);
  const bool regula_falsi = settings.regula_falsi, diagnostics = settings.diagnostics;
  const double limit = settings.divergence_limit, i0 = k.drive.i0;
  const bool plain_shaft = internal::PlainShaft(k.shaft);
  internal::OutputSampler sampler(times, internal::BlmdOutputNames(diagnostics));
  InputCursor input(experiment.input);
  const double t_start = times.front();
  double current[3] = {0.0, 0.0, 0.0};
  double w = experiment.initial.w, theta = experiment.initial.theta;
  Compensators compensators;
  FastLeg legs[3];
  double phase_voltage[3] = {0.0, 0.0, 0.0};
  double torque = 0.0, neutral_voltage = 0.0;
  auto pack = [&](double* row) {
    PackRow(diagnostics, i0, current, w, theta, phase_voltage, torque, neutral_voltage, row);
  };
  double prev[11] = {}, now[11] = {};
  pack(prev);
  sampler.Record(t_start, prev, t_start, prev);
  // The step ending at or past this time records a sample (the sampler's own test).
  auto next_record_time = [&] { return sampler.done() ? 1e300 : sampler.next_time() - 1e-9 * dt; };
  double record_at = next_record_time();

  constexpr double kHalfSqrt3 = 0.86602540378443864676;
  double cos_a = std::cos(k.p * theta), sin_a = std::sin(k.p * theta);
  int until_resync = kResyncSteps;
  double demand = 0.0, demand_next_change = -1e300;
  long index_in_period = 0;
  bool first_step = true;
  double t_high = t_start;        // the previous step's end: this step's start, the same double
  double carrier_high = -k.Vtri;  // CarrierAt(k, 0)
  for (long step = 0; !sampler.done(); ++step) {
    const double t_low = t_high;
    t_high = t_start + static_cast<double>(step + 1) * dt;
    const double t_mid = t_low + 0.5 * dt;
    if (t_mid >= demand_next_change) {  // read again only when the signal can change
      demand = input.At(t_mid);
      demand_next_change = input.NextChange(t_mid);
    }
    const double cosine[3] = {cos_a, -0.5 * cos_a + kHalfSqrt3 * sin_a,
                              -0.5 * cos_a - kHalfSqrt3 * sin_a};
    const double carrier_low = carrier_high;  // CarrierAt(k, index_in_period), last step's end
    carrier_high = CarrierAt(k, index_in_period + 1);
    if (++index_in_period == 2 * k.steps_per_half_period) index_in_period = 0;
    double switched[3], off[3];
    const bool any_off = CompensateAndSwitch(k, regula_falsi, first_step, t_low, t_high, dt, inv_dt,
                                             carrier_low, carrier_high, demand, cosine, current,
                                             &compensators, legs, switched, off);
    first_step = false;
    double leg_voltage[3] = {switched[0], switched[1], switched[2]};
    bool open[3] = {false, false, false};
    if (any_off) BlankedLegVoltages(k, w, cosine, current, switched, off, leg_voltage, open);
    neutral_voltage =
        (leg_voltage[0] + leg_voltage[1] + leg_voltage[2]) / 3.0;  // exact for equal legs
    torque = StepWindings(k, w, cosine, leg_voltage, open, neutral_voltage, phase_voltage, current);
    const double theta_old = theta;
    const bool stopped = StepShaft(k, plain_shaft, dt, torque, &w, &theta);
    const bool resync = --until_resync == 0 || stopped;
    AdvanceElectricalAngle(k.p, theta_old, theta, resync, &cos_a, &sin_a, &until_resync);

    if (!(std::abs(current[0] + i0) <= limit && std::abs(current[1]) <= limit &&
          std::abs(current[2]) <= limit && std::abs(w) <= limit && std::abs(theta) <= limit)) {
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
  WriteDemandColumn(experiment, times, dt, out);
  return SimStatus::Ok();
}

#undef BLMD_STEP_INLINE

}  // namespace

SimStatus BlmdDriveModel::Simulate(const SimulationRequest& request, Trace* out) const {
  if (internal::ForcedEffectAngle(request.settings)) return SimulateReference(request, out);
  return SimulateFast(*this, request, out);
}

}  // namespace blmd
