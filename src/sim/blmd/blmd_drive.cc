#include "blmd/sim/blmd/blmd_drive.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>

#include "blmd/sim/effects.h"
#include "blmd/sim/two_mass.h"
#include "sim/blmd/blmd_events.h"
#include "sim/blmd/blmd_legs.h"
#include "sim/digital_cascade.h"
#include "sim/discretise.h"
#include "sim/input_read.h"
#include "sim/sampler.h"

namespace blmd {
namespace {

ParamInfo P(const char* name, const char* unit, const char* meaning, bool positive, double lo,
            double hi, double typical) {
  ParamInfo info;
  info.name = name;
  info.unit = unit;
  info.meaning = meaning;
  info.positive = positive;
  info.non_negative = !positive;
  info.default_lower = lo;
  info.default_upper = hi;
  info.typical = typical;
  return info;
}

ParamInfo Optional(ParamInfo info) {
  info.optional = true;
  info.default_value = 0.0;
  return info;
}

struct Leg {
  bool upper_commanded = false;  // comparator output: upper switch commanded on
  double t_edge = -1.0;          // s, instant of the last command change
};

// A run's constants of the reference step: the parameters, the backward-Euler coefficients
// and the carrier.
struct ReferenceConstants : internal::BlmdParameters {
  double current_gain;  // i+ = (i + dt/Ls (v - e)) * current_gain
  double speed_gain;    // w+ = (w + dt/J (T)) * speed_gain
  // Lead-lag part: y_k (1 + Tp/dt) - (Tp/dt) y_{k-1} = Kp [(1 + Tz/dt) e_k - (Tz/dt) e_{k-1}]
  double lag_norm;
  double Ki_dt;
  // Carrier: -Vtri at the run's start, +Vtri after Tpwm/2, linear in between; Validate()
  // guarantees Tpwm/2 = steps_per_half_period * dt, so every vertex falls on a step boundary
  // and the carrier is linear inside each step. Indexed by an integer step counter (no
  // floor() of a time, no drift).
  long steps_per_half_period;
  double carrier_slope;  // V per step
  ShaftEffects shaft;
  DriveEffects drive;
  // A two-mass shaft (docs/effects.md, two_mass): the exact zero-order-hold step of
  // [w, theta, w_load, twist] with the torque on the motor held over the step, and the load
  // swinging on a motor that friction holds (TwoMassSides::HeldLoad).
  bool flexible = false;
  TwoMassSides sides;
  Eigen::Matrix4d flexible_Ad = Eigen::Matrix4d::Identity();
  Eigen::Vector4d flexible_Bd = Eigen::Vector4d::Zero();
  Eigen::Matrix2d held_load = Eigen::Matrix2d::Identity();

  static ReferenceConstants From(const ParameterSet& values,
                                 const std::vector<std::string>& effects,
                                 const SimulationSettings& settings) {
    const double dt = settings.dt;
    ReferenceConstants c;
    static_cast<BlmdParameters&>(c) = BlmdParameters::From(values);
    c.shaft = ShaftEffects::From(values, effects, settings.friction_smoothing_w);
    c.drive = DriveEffects::From(values, effects);
    c.current_gain = 1.0 / (1.0 + dt * c.Rs / c.Ls);
    c.speed_gain = 1.0 / (1.0 + dt * c.B / c.J);
    c.lag_norm = 1.0 / (1.0 + c.Tp / dt);
    c.Ki_dt = c.Ki * dt;
    c.steps_per_half_period = std::lround(0.5 * c.Tpwm / dt);
    c.carrier_slope = 2.0 * c.Vtri / static_cast<double>(c.steps_per_half_period);
    c.flexible = c.shaft.two_mass();
    if (c.flexible) {
      c.sides = c.shaft.Sides(c.J, c.B);
      Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
      c.sides.SetRows(0, 2, 3, &A);
      A(1, 0) = 1.0;
      Eigen::Vector4d input = Eigen::Vector4d::Zero();
      input(0) = 1.0 / c.sides.Jm;  // the net torque on the motor, N·m
      internal::Discretise<4, 1>(A, input, dt, &c.flexible_Ad, &c.flexible_Bd);
      c.held_load = (c.sides.HeldLoad() * dt).exp();
    }
    return c;
  }

  // The carrier at a step boundary, index_in_period in [0, 2N].
  double CarrierAt(long index_in_period) const {
    return index_in_period <= steps_per_half_period
               ? -Vtri + carrier_slope * static_cast<double>(index_in_period)
               : Vtri -
                     carrier_slope * static_cast<double>(index_in_period - steps_per_half_period);
  }
};

// The state of the drive (windings, compensators, legs) and of the shaft.
struct ReferenceState {
  std::array<double, 3> current = {0.0, 0.0, 0.0};     // A, into the winding
  std::array<double, 3> integral = {0.0, 0.0, 0.0};    // V, compensator integrator
  std::array<double, 3> lead_out = {0.0, 0.0, 0.0};    // V, lead-lag output
  std::array<double, 3> error_prev = {0.0, 0.0, 0.0};  // V
  std::array<Leg, 3> legs;
  std::array<double, 3> phase_voltage = {0.0, 0.0, 0.0};  // V
  double torque = 0.0, neutral_voltage = 0.0;             // N·m, V
  double w = 0.0, theta = 0.0;                            // rad/s, rad
  double w_load = 0.0, twist = 0.0;  // rad/s, rad: a two-mass shaft's load and θ − θ_load

  // The output row: u, the currents (ia as measured, with i0), w, theta, and with
  // diagnostics the phase voltages, torque and neutral voltage.
  void Pack(double u, double i0, bool diagnostics, double* row) const {
    row[0] = u;
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
};

// Phase j's compensator from its current error: the control voltage in [-Vtri, Vtri].
[[gnu::always_inline]] inline double ReferenceCompensate(const ReferenceConstants& c, double dt,
                                                         int j, double error, ReferenceState* s) {
  s->lead_out[j] =
      c.lag_norm * ((c.Tp / dt) * s->lead_out[j] +
                    c.Kp * ((1.0 + c.Tz / dt) * error - (c.Tz / dt) * s->error_prev[j]));
  s->error_prev[j] = error;
  // Conditional integration: the integrator holds while the output saturates in the
  // direction of the error (anti-windup).
  const double proposed_integral = s->integral[j] + c.Ki_dt * error;
  const double unclamped = s->lead_out[j] + proposed_integral;
  if (std::abs(unclamped) <= c.Vtri || unclamped * error < 0.0) s->integral[j] = proposed_integral;
  return std::clamp(s->lead_out[j] + s->integral[j], -c.Vtri, c.Vtri);
}

// A PWM leg over the step [t_low, t_high] with the carrier minus the control at its ends
// d_low, d_high (< 0: upper commanded): the upper switch's conduction time and the both-off
// (blanking) time, s. On the first step the leg starts settled on its command.
[[gnu::always_inline]] inline void ReferenceLegStep(const ReferenceConstants& c, bool regula_falsi,
                                                    bool first_step, double dt, double t_low,
                                                    double t_high, double d_low, double d_high,
                                                    Leg* leg, double* upper_on, double* off_time) {
  if (first_step) {
    leg->upper_commanded = d_low < 0.0;
    leg->t_edge = t_low - 2.0 * c.delta - dt;  // settled before the run
  }
  *upper_on = 0.0;
  *off_time = 0.0;
  auto conduct = [&](double a, double b) {  // [a, b] under the present command
    if (leg->upper_commanded) *upper_on += internal::ConductingTime(a, b, leg->t_edge, c.delta);
    // Blanking part [a, min(b, t_edge + delta)]: both switches off; the diodes (or
    // neither: an open phase) decide the leg voltage, see internal::LegSolver.
    *off_time += std::max(0.0, std::min(b, leg->t_edge + c.delta) - a);
  };
  // Comparator at the step start with this step's control voltage: the control may have
  // moved across the carrier since the previous step (an edge at t_low).
  if ((d_low < 0.0) != leg->upper_commanded) {
    leg->upper_commanded = d_low < 0.0;
    leg->t_edge = t_low;
  }
  // A crossing inside the step (control held, carrier linear: at most one), located by
  // regula falsi, t_x = t_L + dt d_L / (d_L - d_H), exact here. Without regula falsi
  // the comparator is only sampled at step boundaries, so this crossing is seen at the
  // next step's start.
  if (regula_falsi && (d_high < 0.0) != leg->upper_commanded) {
    const double t_cross = t_low + dt * d_low / (d_low - d_high);
    conduct(t_low, t_cross);
    leg->upper_commanded = d_high < 0.0;
    leg->t_edge = t_cross;
    conduct(t_cross, t_high);
  } else {
    conduct(t_low, t_high);
  }
}

// The windings over the step (backward Euler), back-EMF from the step-start speed and angle:
// the neutral and phase voltages, the currents at the step's end and the torque.
[[gnu::always_inline]] inline void ReferenceWindings(const ReferenceConstants& c, double dt,
                                                     const std::array<double, 3>& cosine,
                                                     const std::array<double, 3>& leg_voltage,
                                                     const std::array<bool, 3>& open,
                                                     ReferenceState* s) {
  s->neutral_voltage = (leg_voltage[0] + leg_voltage[1] + leg_voltage[2]) / 3.0;
  s->torque = 0.0;
  for (int j = 0; j < 3; ++j) {
    s->phase_voltage[j] = leg_voltage[j] - s->neutral_voltage;
    const double emf = c.Ke * s->w * cosine[j];
    s->current[j] =
        open[j] ? 0.0 : (s->current[j] + dt / c.Ls * (s->phase_voltage[j] - emf)) * c.current_gain;
    s->torque += c.Ke * s->current[j] * cosine[j];
  }
}

// The shaft over the step (backward Euler) with the shared effects, cogging at the angle
// effect_theta; a shaft that friction stops inside the step ends it at rest.
[[gnu::always_inline]] inline void ReferenceShaft(const ReferenceConstants& c, double dt,
                                                  double effect_theta, ReferenceState* s) {
  const ShaftEffects& shaft = c.shaft;
  const double w_old = s->w, theta_old = s->theta;
  const double non_friction = shaft.NonFrictionTorque(effect_theta) + shaft.DragTorque(s->w);
  bool stuck = false;
  const double friction = shaft.StepFriction(s->w, s->torque - non_friction, &stuck);
  if (stuck) return;
  s->w = (s->w + dt / c.J * (s->torque - friction - non_friction)) * c.speed_gain;
  if (shaft.StopsWithin(w_old, s->w)) {
    const double fraction = w_old / (w_old - s->w);
    s->w = 0.0;
    s->theta = theta_old + 0.5 * w_old * fraction * dt;
  } else {
    s->theta += dt * s->w;
  }
}

// A two-mass shaft over the step (§10a): the exact step of [w, theta, w_load, twist] with the
// drive's torque and the effects' held, the load's torque K twist + c (w − w_load) on the motor
// deciding whether static friction holds it; a held motor lets the load swing.
[[gnu::always_inline]] inline void ReferenceFlexibleShaft(const ReferenceConstants& c,
                                                          double effect_theta, ReferenceState* s) {
  const ShaftEffects& shaft = c.shaft;
  const double non_friction = shaft.NonFrictionTorque(effect_theta) + shaft.DragTorque(s->w);
  const double coupling = c.sides.K * s->twist + c.sides.c * (s->w - s->w_load);
  bool stuck = false;
  const double friction = shaft.StepFriction(s->w, s->torque - non_friction - coupling, &stuck);
  if (stuck) {
    const Eigen::Vector2d load = c.held_load * Eigen::Vector2d(s->w_load, s->twist);
    s->w_load = load(0);
    s->twist = load(1);
    return;
  }
  const Eigen::Vector4d x = c.flexible_Ad * Eigen::Vector4d(s->w, s->theta, s->w_load, s->twist) +
                            c.flexible_Bd * (s->torque - friction - non_friction);
  s->w = shaft.StopsWithin(s->w, x(0)) ? 0.0 : x(0);
  s->theta = x(1);
  s->w_load = x(2);
  s->twist = x(3);
}

}  // namespace

// Typical values: the 1.5 kW D31x-class drive of configs/blmd-d31x.json (Guinee & Lyden 1999;
// the values the paper does not give are plausible ones, noted there).
const std::vector<ParamInfo>& BlmdDriveModel::parameters() const {
  static const std::vector<ParamInfo> params = {
      P("Ud", "V", "DC bus voltage", true, 1.0, 2000.0, 310.0),
      P("Rs", "ohm", "phase resistance", true, 1e-3, 100.0, 1.0),
      P("Ls", "H", "phase inductance", true, 1e-6, 1.0, 0.004),
      P("Ke", "V·s/rad", "back-EMF and torque constant Ke = p lambda_m (phase peak)", true, 1e-3,
        10.0, 0.3),
      P("p", "-", "pole pairs", true, 1.0, 50.0, 3.0),
      P("Kc", "V/V", "current demand per volt of torque demand", true, 1e-3, 100.0, 1.1),
      // Kf = 0 (with Ki = 0) opens the current loop: v_cj = Kp Kc Td cos(...), a fixed duty
      // for a fixed rotor angle (open-loop voltage mode, docs/model-blmd.md).
      P("Kf", "V/A", "current feedback gain (0: current loop open)", false, 1e-3, 100.0, 0.5),
      P("Kp", "V/V", "compensator proportional gain", false, 0.0, 1e3, 8.0),
      P("Ki", "1/s", "compensator integral gain", false, 0.0, 1e7, 16000.0),
      Optional(P("Tz", "s", "compensator lead zero time constant (0: PI)", false, 0.0, 1.0, 0.0)),
      Optional(P("Tp", "s", "compensator lag pole time constant (0: PI)", false, 0.0, 1.0, 0.0)),
      P("Vtri", "V", "carrier peak (control voltage for full duty)", true, 1e-3, 100.0, 10.0),
      P("Tpwm", "s", "carrier (switching) period, the paper's Ts", true, 1e-6, 1e-2, 2e-4),
      P("delta", "s", "blanking (dead) time on every turn-on", false, 0.0, 1e-3, 2e-5),
      P("J", "kg·m²", "inertia of rotor, shaft and load", true, 1e-7, 10.0, 1.19e-3),
      P("B", "N·m·s/rad", "viscous damping", true, 1e-9, 10.0, 5e-4),
  };
  return params;
}

// The events integration by default: faster than the fixed 1 µs step at a smaller error in
// both the current and the speed (docs/performance.md §7, bench/events_bench.cc). A config names
// fixed_euler to get the paper's integration (the bundled configs do: their figures and studies
// were made with it).
SimulationSettings BlmdDriveModel::default_settings() const {
  SimulationSettings settings;
  settings.dt = 1e-6;
  settings.method = SimulationMethod::kEvents;
  return settings;
}

// A torque-demand input (V); 0.16 s at 50 kHz resolves the PWM and current loops' response
// (docs/model-blmd.md); the phase current observed, as the paper's figures show it.
ModelTraits BlmdDriveModel::traits() const {
  ModelTraits traits;
  traits.default_duration = 0.16;
  traits.default_sample_rate = 50000.0;
  traits.default_observe = {"i"};
  traits.event_integrator = true;
  traits.sampled_pid = true;
  traits.own_current_loop = true;
  traits.input_limit = 10.0;  // V: Td is linear in ±10 V (docs/model-blmd.md §1)
  return traits;
}

std::string BlmdDriveModel::Validate(const ParameterSet& values,
                                     const SimulationSettings& settings) const {
  if (std::string error = Model::Validate(values, settings); !error.empty()) return error;
  const double half_period = 0.5 * values.Get("Tpwm");
  const double ratio = half_period / settings.dt;
  if (std::abs(ratio - std::round(ratio)) > 1e-6 * ratio || std::round(ratio) < 2.0) {
    return "Tpwm/2 must be a whole number (>= 2) of simulation steps dt";
  }
  if (values.Get("delta") >= half_period) return "delta must be shorter than Tpwm/2";
  if (settings.method == SimulationMethod::kEvents) {
    return internal::EventsUnsupported(values.Get("Tz"), values.Get("Tp"));
  }
  return {};
}

SimStatus BlmdDriveModel::SimulateReference(const SimulationRequest& request, Trace* out) const {
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const SimulationSettings& settings = request.settings;
  const double dt = settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const ReferenceConstants c =
      ReferenceConstants::From(*request.parameters, *request.effects, settings);
  // Closed loop (experiment.pid): the drive's digital speed PI (or position P over it) gives
  // the torque demand, sampling w and theta every `period` steps; its output is held, and
  // the reference r is an extra output column after the others.
  const bool closed_loop = experiment.closed_loop;
  const long period = closed_loop ? internal::ControllerPeriodSteps(experiment.pid, dt) : 1;
  if (period < 1) {
    return {SimStatus::Code::kInvalidParameters,
            "the controller's period is not a whole number of simulation steps", times.front()};
  }
  std::vector<std::string> names = internal::BlmdOutputNames(settings.diagnostics);
  const std::size_t r_index = names.size();  // the row's slot for r (closed loop)
  if (closed_loop) names.emplace_back("r");
  const std::size_t load_index = names.size();  // w_load, theta_load (a two-mass shaft)
  if (c.flexible) names.insert(names.end(), {"w_load", "theta_load"});  // a load-side encoder
  internal::OutputSampler sampler(times, names);
  InputCursor input(experiment.input);
  const double Ts = experiment.pid.sample_rate > 0.0 ? 1.0 / experiment.pid.sample_rate : dt;
  internal::DigitalCascade controller(experiment.pid, Ts);

  const double t_start = times.front();
  ReferenceState s;
  s.w = experiment.initial.w;
  s.theta = experiment.initial.theta;
  s.w_load = experiment.initial.LoadSpeed();  // a two-mass shaft's load (InitialState)
  s.twist = experiment.initial.twist;
  double reference = input.At(internal::InputReadTime(t_start, dt));
  double command = closed_loop ? controller.Tick(reference, s.w, s.theta) : 0.0;  // V
  std::array<double, 14> prev{}, now{};
  auto pack = [&](double u, double* row) {
    s.Pack(u, c.drive.i0, settings.diagnostics, row);
    if (closed_loop) row[r_index] = reference;
    if (c.flexible) {
      row[load_index] = s.w_load;
      row[load_index + 1] = s.theta - s.twist;
    }
  };
  pack(closed_loop ? command : input.At(t_start), prev.data());
  sampler.Record(t_start, prev.data(), t_start, prev.data());

  constexpr double kHalfSqrt3 = 0.86602540378443864676;  // sin(2 pi/3)
  long index_in_period = 0;  // step start within the carrier period, 0 .. 2N-1
  bool first_step = true;
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  for (long step = 0; !sampler.done(); ++step) {
    const double t_low = t_start + static_cast<double>(step) * dt;
    const double t_high = t_start + static_cast<double>(step + 1) * dt;
    // The demand over a step is read just after its midpoint (sim/input_read.h), so that an
    // event on the step grid (a step's t0, a square wave's edge, a recorded sample) takes
    // effect exactly there whatever the rounding of t_start + k dt (as dc_servo does).
    const double demand = closed_loop ? command : input.At(internal::InputReadTime(t_low, dt));
    // cos(p theta - 2(j-1)pi/3) from one sine/cosine pair: the b and c phases are the a
    // phase rotated by -120 and -240 degrees.
    const double electrical_angle = c.p * s.theta;
    const double cos_a = std::cos(electrical_angle), sin_a = std::sin(electrical_angle);
    const std::array<double, 3> cosine = {cos_a, -0.5 * cos_a + kHalfSqrt3 * sin_a,
                                          -0.5 * cos_a - kHalfSqrt3 * sin_a};

    // Compensators and PWM legs.
    const double carrier_low = c.CarrierAt(index_in_period);
    const double carrier_high = c.CarrierAt(index_in_period + 1);
    if (++index_in_period == 2 * c.steps_per_half_period) index_in_period = 0;
    std::array<double, 3> switched, off, hold;
    for (int j = 0; j < 3; ++j) {
      const double error = c.Kc * demand * cosine[j] - c.Kf * s.current[j];
      const double control = ReferenceCompensate(c, dt, j, error, &s);
      double upper_on, off_time;  // s, upper switch on / both off, in the step
      ReferenceLegStep(c, settings.regula_falsi, first_step, dt, t_low, t_high,
                       carrier_low - control, carrier_high - control, &s.legs[j], &upper_on,
                       &off_time);
      switched[j] = c.Ud * upper_on / dt;
      off[j] = off_time / dt;
      hold[j] = c.Ke * s.w * cosine[j] - c.Ls / dt * s.current[j];
    }
    first_step = false;
    // Diodes and open phases, decided at the step's end (eqs. 12-14).
    std::array<double, 3> leg_voltage = switched;
    std::array<bool, 3> open = {false, false, false};
    if (off[0] > 0.0 || off[1] > 0.0 || off[2] > 0.0) {
      internal::LegSolver::Solve(switched.data(), off.data(), hold.data(), s.current.data(), c.Ud,
                                 leg_voltage.data(), open.data());
    }
    ReferenceWindings(c, dt, cosine, leg_voltage, open, &s);
    if (c.flexible) {
      ReferenceFlexibleShaft(c, effect_angle.At(t_low, s.theta), &s);
    } else {
      ReferenceShaft(c, dt, effect_angle.At(t_low, s.theta), &s);
    }

    if (closed_loop && (step + 1) % period == 0) {
      // The controller samples at t_high; its command holds from there on (recorded with
      // the state at t_high, as rigid_load's closed loop records it).
      reference = input.At(internal::InputReadTime(t_high, dt));
      command = controller.Tick(reference, s.w, s.theta);
    }
    pack(closed_loop ? command : demand, now.data());
    const std::array<double, 2> load = {s.w_load, s.twist};
    if (!internal::AllFinite(now.data() + 1, 5, settings.divergence_limit) ||
        (c.flexible && !internal::AllFinite(load.data(), 2, settings.divergence_limit))) {
      return {SimStatus::Code::kDiverged, internal::DivergedMessage(settings.divergence_limit),
              t_high};
    }
    sampler.Record(t_low, prev.data(), t_high, now.data());
    prev = now;
  }
  sampler.Finish(out);
  if (closed_loop) return SimStatus::Ok();
  auto& u_column = out->Column("u");
  // u at a sample: the demand applied from that instant on (read as the steps read it), so
  // that a trace replays exactly through its u column as a recorded input.
  // (a cursor: the sample times increase, so each read continues where the last stopped)
  InputCursor u_cursor(experiment.input);
  for (std::size_t k = 0; k < times.size(); ++k)
    u_column[k] = u_cursor.At(internal::InputReadTime(times[k], dt));
  return SimStatus::Ok();
}

double BlmdDriveModel::CurrentLoopBandwidthHz(const ParameterSet& values) const {
  const internal::BlmdParameters c = internal::BlmdParameters::From(values);
  if (!(c.Kf > 0.0)) return 0.0;                  // current loop open: no current loop to speak of
  const double pwm_gain = c.Ud / (2.0 * c.Vtri);  // V of phase voltage per V of control
  auto closed = [&](double omega) {               // |T(j omega)|, T the closed current loop
    const std::complex<double> s(0.0, omega);
    std::complex<double> compensator = c.Kp * (1.0 + s * c.Tz) / (1.0 + s * c.Tp);
    if (c.Ki > 0.0) compensator += c.Ki / s;
    const std::complex<double> loop = c.Kf * compensator * pwm_gain / (c.Ls * s + c.Rs);
    return std::abs(loop / (1.0 + loop));
  };
  const double dc = c.Ki > 0.0 ? 1.0 : closed(1e-9 * c.Rs / c.Ls);
  const double target = dc / std::sqrt(2.0);
  // The first fall through -3 dB on a logarithmic grid from 1e-3 of the winding's corner
  // frequency Rs/Ls up, then bisection (in log omega) inside that cell.
  double low = 1e-3 * c.Rs / c.Ls;
  for (int k = 0; k < 400 && closed(low * 1.1) > target; ++k) low *= 1.1;
  double high = low * 1.1;
  if (closed(high) > target) return 0.0;  // no fall within 1e16 of the corner: ideal
  for (int k = 0; k < 60; ++k) {
    const double mid = std::sqrt(low * high);
    (closed(mid) > target ? low : high) = mid;
  }
  return std::sqrt(low * high) / (2.0 * std::numbers::pi);
}

double BlmdDriveModel::SpeedLimit(const ParameterSet& values) const {
  return values.Get("Ud") / (2.0 * values.Get("Ke"));
}

double BlmdDriveModel::DriveTorqueScale(const ParameterSet& values, double i_max, double /*u_max*/,
                                        double /*w_max*/) const {
  return 1.5 * values.Get("Ke") * i_max;
}

// The drive with ideal current loops (docs/model-blmd.md, "Linear part"): each phase
// current follows its demand i_j = (Kc/Kf)·Td·cos(p·theta - 2(j-1)pi/3), so
// Te = Ke·sum_j i_j·cos(...) = 1.5·Ke·Kc/Kf·Td, and J dw/dt = Te - B w (or the two-mass shaft
// driven by Te, LinearShaft). The phase current is
// modulated by the rotor angle, so u -> i is not time-invariant and is not given.
LinearModel BlmdDriveModel::Linearise(const ParameterSet& values) const {
  LinearModel model;
  const double Kf = values.Get("Kf");
  if (!(Kf > 0.0)) {
    model.reason =
        "Kf = 0: the current loop is open (voltage mode), so the torque is not "
        "proportional to the demand";
    return model;
  }
  const double torque_per_volt = 1.5 * values.Get("Ke") * values.Get("Kc") / Kf;  // N·m/V
  model.input = "u = Td (V, the torque demand)";
  LinearShaft(values, torque_per_volt, &model);
  model.assumption = std::string("ideal current loops (Te = 1.5·Ke·Kc/Kf·Td); ") +
                     (model.has_shaft ? "the two-mass shaft kept; " : "") +
                     "PWM, dead time and the effects left out";
  return model;
}

}  // namespace blmd
