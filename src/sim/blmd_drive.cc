#include "blmd/sim/blmd_drive.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "blmd/sim/effects.h"
#include "sim/blmd_legs.h"
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

SimulationSettings BlmdDriveModel::default_settings() const {
  SimulationSettings settings;
  settings.dt = 1e-6;
  return settings;
}

// A torque-demand input (V); 0.16 s at 50 kHz resolves the PWM and current loops' response
// (docs/model-blmd.md); the phase current observed, as the paper's figures show it.
ModelTraits BlmdDriveModel::traits() const {
  ModelTraits traits;
  traits.default_duration = 0.16;
  traits.default_sample_rate = 50000.0;
  traits.default_observe = {"i"};
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
  return {};
}

SimStatus BlmdDriveModel::SimulateReference(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const SimulationSettings& settings = request.settings;
  const double dt = settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const double Ud = values.Get("Ud"), Rs = values.Get("Rs"), Ls = values.Get("Ls"),
               Ke = values.Get("Ke"), p = values.Get("p"), Kc = values.Get("Kc"),
               Kf = values.Get("Kf"), Kp = values.Get("Kp"), Ki = values.Get("Ki"),
               Tz = values.Get("Tz"), Tp = values.Get("Tp"), Vtri = values.Get("Vtri"),
               Tpwm = values.Get("Tpwm"), delta = values.Get("delta"), J = values.Get("J"),
               B = values.Get("B");
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, settings.friction_smoothing_w);
  const DriveEffects drive = DriveEffects::From(values, *request.effects);

  // Backward-Euler coefficients.
  const double current_gain = 1.0 / (1.0 + dt * Rs / Ls);  // i+ = (i + dt/Ls (v - e)) * gain
  const double speed_gain = 1.0 / (1.0 + dt * B / J);      // w+ = (w + dt/J (T)) * gain
  // Lead-lag part: y_k (1 + Tp/dt) - (Tp/dt) y_{k-1} = Kp [(1 + Tz/dt) e_k - (Tz/dt) e_{k-1}]
  const double lag_norm = 1.0 / (1.0 + Tp / dt);
  const double Ki_dt = Ki * dt;

  // Carrier: -Vtri at the run's start, +Vtri after Tpwm/2, linear in between; Validate()
  // guarantees Tpwm/2 = steps_per_half_period * dt, so every vertex falls on a step boundary
  // and the carrier is linear inside each step. Indexed by an integer step counter (no
  // floor() of a time, no drift).
  const long steps_per_half_period = std::lround(0.5 * Tpwm / dt);
  const double carrier_slope = 2.0 * Vtri / static_cast<double>(steps_per_half_period);
  auto carrier_at = [&](long index_in_period) {  // index_in_period in [0, 2N]
    return index_in_period <= steps_per_half_period
               ? -Vtri + carrier_slope * static_cast<double>(index_in_period)
               : Vtri -
                     carrier_slope * static_cast<double>(index_in_period - steps_per_half_period);
  };

  internal::OutputSampler sampler(times, internal::BlmdOutputNames(settings.diagnostics));
  InputCursor input(experiment.input);

  const double t_start = times.front();
  std::array<double, 3> current = {0.0, 0.0, 0.0};  // A, into the winding
  double w = experiment.initial.w, theta = experiment.initial.theta;
  std::array<double, 3> integral = {0.0, 0.0, 0.0};  // V, compensator integrator
  std::array<double, 3> lead_out = {0.0, 0.0, 0.0};  // V, lead-lag output
  std::array<double, 3> error_prev = {0.0, 0.0, 0.0};
  std::array<Leg, 3> legs;
  std::array<double, 3> phase_voltage = {0.0, 0.0, 0.0};
  double torque = 0.0, neutral_voltage = 0.0;

  auto pack = [&](double u, double* row) {
    row[0] = u;
    row[1] = current[0] + drive.i0;
    row[2] = current[1];
    row[3] = current[2];
    row[4] = w;
    row[5] = theta;
    if (settings.diagnostics) {
      row[6] = phase_voltage[0];
      row[7] = phase_voltage[1];
      row[8] = phase_voltage[2];
      row[9] = torque;
      row[10] = neutral_voltage;
    }
  };
  std::array<double, 11> prev{}, now{};
  pack(input.At(t_start), prev.data());
  sampler.Record(t_start, prev.data(), t_start, prev.data());

  constexpr double kHalfSqrt3 = 0.86602540378443864676;  // sin(2 pi/3)
  long index_in_period = 0;  // step start within the carrier period, 0 .. 2N-1
  bool first_step = true;
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  for (long step = 0; !sampler.done(); ++step) {
    const double t_low = t_start + static_cast<double>(step) * dt;
    const double t_high = t_start + static_cast<double>(step + 1) * dt;
    // The demand over a step is read at its midpoint, so that an event on the step grid (a
    // step's t0, a square wave's edge, a recorded sample) takes effect exactly there whatever
    // the rounding of t_start + k dt (as dc_servo does).
    const double demand = input.At(t_low + 0.5 * dt);
    // cos(p theta - 2(j-1)pi/3) from one sine/cosine pair: the b and c phases are the a
    // phase rotated by -120 and -240 degrees.
    const double electrical_angle = p * theta;
    const double cos_a = std::cos(electrical_angle), sin_a = std::sin(electrical_angle);
    const std::array<double, 3> cosine = {cos_a, -0.5 * cos_a + kHalfSqrt3 * sin_a,
                                          -0.5 * cos_a - kHalfSqrt3 * sin_a};

    // Compensators and PWM legs.
    const double carrier_low = carrier_at(index_in_period);
    const double carrier_high = carrier_at(index_in_period + 1);
    if (++index_in_period == 2 * steps_per_half_period) index_in_period = 0;
    std::array<double, 3> switched, off, hold;
    for (int j = 0; j < 3; ++j) {
      const double error = Kc * demand * cosine[j] - Kf * current[j];
      lead_out[j] = lag_norm * ((Tp / dt) * lead_out[j] +
                                Kp * ((1.0 + Tz / dt) * error - (Tz / dt) * error_prev[j]));
      error_prev[j] = error;
      // Conditional integration: the integrator holds while the output saturates in the
      // direction of the error (anti-windup).
      const double proposed_integral = integral[j] + Ki_dt * error;
      const double unclamped = lead_out[j] + proposed_integral;
      if (std::abs(unclamped) <= Vtri || unclamped * error < 0.0) integral[j] = proposed_integral;
      const double control = std::clamp(lead_out[j] + integral[j], -Vtri, Vtri);

      Leg& leg = legs[j];
      const double d_low = carrier_low - control;  // < 0: upper commanded
      const double d_high = carrier_high - control;
      if (first_step) {
        leg.upper_commanded = d_low < 0.0;
        leg.t_edge = t_low - 2.0 * delta - dt;  // settled before the run
      }
      double upper_on = 0.0, off_time = 0.0;    // s, upper switch on / both off, in the step
      auto conduct = [&](double a, double b) {  // [a, b] under the present command
        if (leg.upper_commanded) upper_on += internal::ConductingTime(a, b, leg.t_edge, delta);
        // Blanking part [a, min(b, t_edge + delta)]: both switches off; the diodes (or
        // neither: an open phase) decide the leg voltage, see internal::LegSolver.
        off_time += std::max(0.0, std::min(b, leg.t_edge + delta) - a);
      };
      // Comparator at the step start with this step's control voltage: the control may have
      // moved across the carrier since the previous step (an edge at t_low).
      if ((d_low < 0.0) != leg.upper_commanded) {
        leg.upper_commanded = d_low < 0.0;
        leg.t_edge = t_low;
      }
      // A crossing inside the step (control held, carrier linear: at most one), located by
      // regula falsi, t_x = t_L + dt d_L / (d_L - d_H), exact here. Without regula falsi
      // the comparator is only sampled at step boundaries, so this crossing is seen at the
      // next step's start.
      if (settings.regula_falsi && (d_high < 0.0) != leg.upper_commanded) {
        const double t_cross = t_low + dt * d_low / (d_low - d_high);
        conduct(t_low, t_cross);
        leg.upper_commanded = d_high < 0.0;
        leg.t_edge = t_cross;
        conduct(t_cross, t_high);
      } else {
        conduct(t_low, t_high);
      }
      switched[j] = Ud * upper_on / dt;
      off[j] = off_time / dt;
      hold[j] = Ke * w * cosine[j] - Ls / dt * current[j];
    }
    first_step = false;
    // Diodes and open phases, decided at the step's end (eqs. 12-14).
    std::array<double, 3> leg_voltage = switched;
    std::array<bool, 3> open = {false, false, false};
    if (off[0] > 0.0 || off[1] > 0.0 || off[2] > 0.0) {
      internal::LegSolver::Solve(switched.data(), off.data(), hold.data(), current.data(), Ud,
                                 leg_voltage.data(), open.data());
    }
    neutral_voltage = (leg_voltage[0] + leg_voltage[1] + leg_voltage[2]) / 3.0;

    // Windings (backward Euler), back-EMF from the step-start speed and angle.
    torque = 0.0;
    for (int j = 0; j < 3; ++j) {
      phase_voltage[j] = leg_voltage[j] - neutral_voltage;
      const double emf = Ke * w * cosine[j];
      current[j] = open[j] ? 0.0 : (current[j] + dt / Ls * (phase_voltage[j] - emf)) * current_gain;
      torque += Ke * current[j] * cosine[j];
    }

    // Shaft (backward Euler) with the shared effects.
    const double w_old = w, theta_old = theta;
    const double non_friction =
        shaft.NonFrictionTorque(effect_angle.At(t_low, theta)) + shaft.DragTorque(w);
    bool stuck = false;
    const double friction = shaft.StepFriction(w, torque - non_friction, &stuck);
    if (!stuck) {
      w = (w + dt / J * (torque - friction - non_friction)) * speed_gain;
      if (shaft.StopsWithin(w_old, w)) {
        const double fraction = w_old / (w_old - w);
        w = 0.0;
        theta = theta_old + 0.5 * w_old * fraction * dt;
      } else {
        theta += dt * w;
      }
    }

    pack(demand, now.data());
    if (!internal::AllFinite(now.data() + 1, 5, settings.divergence_limit)) {
      return {SimStatus::Code::kDiverged, internal::DivergedMessage(settings.divergence_limit),
              t_high};
    }
    sampler.Record(t_low, prev.data(), t_high, now.data());
    prev = now;
  }
  sampler.Finish(out);
  auto& u_column = out->Column("u");
  // u at a sample: the demand applied from that instant on (read as the steps read it), so
  // that a trace replays exactly through its u column as a recorded input.
  for (std::size_t k = 0; k < times.size(); ++k) {
    u_column[k] = experiment.input.At(times[k] + 0.5 * dt);
  }
  return SimStatus::Ok();
}

double BlmdDriveModel::DriveTorqueScale(const ParameterSet& values, double i_max, double /*u_max*/,
                                        double /*w_max*/) const {
  return 1.5 * values.Get("Ke") * i_max;
}

// The drive with ideal current loops (docs/model-blmd.md, "Linear part"): each phase
// current follows its demand i_j = (Kc/Kf)·Td·cos(p·theta - 2(j-1)pi/3), so
// Te = Ke·sum_j i_j·cos(...) = 1.5·Ke·Kc/Kf·Td, and J dw/dt = Te - B w. The phase current is
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
  const double J = values.Get("J"), B = values.Get("B");
  model.available = true;
  model.input = "u = Td (V, the torque demand)";
  model.assumption =
      "ideal current loops (Te = 1.5·Ke·Kc/Kf·Td); PWM, dead time and the "
      "effects left out";
  model.states = {"w", "theta"};
  model.outputs = model.states;
  model.A.resize(2, 2);
  model.A << -B / J, 0.0, 1.0, 0.0;
  model.B.resize(2, 1);
  model.B << torque_per_volt / J, 0.0;
  model.C = Eigen::MatrixXd::Identity(2, 2);
  model.D = Eigen::MatrixXd::Zero(2, 1);
  return model;
}

}  // namespace blmd
