#include "blmd/sim/dc_servo/dc_servo.h"

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "blmd/sim/effects.h"
#include "sim/dc_servo/dc_servo_steps.h"
#include "sim/input_read.h"
#include "sim/sampler.h"

namespace blmd {
namespace {

ParamInfo P(const char* name, const char* unit, const char* meaning, double lo, double hi,
            double typical) {
  ParamInfo info;
  info.name = name;
  info.unit = unit;
  info.meaning = meaning;
  info.positive = true;
  info.default_lower = lo;
  info.default_upper = hi;
  info.typical = typical;
  return info;
}

double Sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

// One step of the reference from x = [i, w, theta] under the voltage u_eff, the armature closed
// or open (i = 0), with the shaft's effects (friction with sticking, drag, cogging at the
// angle effect_theta). A shaft that friction stops inside the step stops there, and breaks
// away for the rest of the step when the torque at rest (Kt i at the step's end minus the
// positional effects) exceeds the breakaway torque (ShaftEffects::StopInStep).
[[gnu::always_inline]] inline void ReferenceStep(const internal::DcServoDiscretisation& d,
                                                 const ShaftEffects& shaft, double Kt, double J,
                                                 double B, double dt, bool open, double u_eff,
                                                 double effect_theta, double* i, double* w,
                                                 double* theta) {
  const double positional = shaft.NonFrictionTorque(effect_theta);
  const double non_friction = positional + shaft.DragTorque(*w);
  const double w_old = *w, theta_old = *theta;
  if (open) {
    *i = 0.0;
    bool stuck = false;
    const double friction = shaft.StepFriction(*w, -non_friction, &stuck);
    if (!stuck) {
      const Eigen::Vector2d x =
          d.Ado * Eigen::Vector2d(*w, *theta) + d.Bdo * (friction + non_friction);
      *w = x(0);
      *theta = x(1);
    }
  } else {
    bool stuck = false;
    const double friction = shaft.StepFriction(*w, Kt * *i - non_friction, &stuck);
    if (stuck) {
      *i = d.Ads(0, 0) * *i + d.Bds(0, 0) * u_eff;
    } else {
      const Eigen::Vector3d x = d.Ad * Eigen::Vector3d(*i, *w, *theta) +
                                d.Bd * Eigen::Vector2d(u_eff, friction + non_friction);
      *i = x(0);
      *w = x(1);
      *theta = x(2);
    }
  }
  shaft.StopInStep(w_old, theta_old, dt, J, B, Kt * *i - positional, w, theta);
}

}  // namespace

// Typical values: the no-load servo of Ganesh et al. (2012) (configs/ganesh-noload.json).
const std::vector<ParamInfo>& DcServoModel::parameters() const {
  static const std::vector<ParamInfo> params = {
      P("R", "ohm", "armature resistance", 1e-3, 1e3, 12.6),
      P("L", "H", "armature inductance", 1e-6, 10.0, 0.283),
      P("Kt", "N·m/A", "torque constant", 1e-4, 10.0, 0.04),
      P("Kb", "V·s/rad", "back-EMF constant", 1e-4, 10.0, 0.04),
      P("J", "kg·m²", "inertia of motor and load", 1e-9, 10.0, 2.26e-5),
      P("B", "N·m·s/rad", "viscous damping of motor and load", 1e-10, 10.0, 2.261e-5),
  };
  return params;
}

SimulationSettings DcServoModel::default_settings() const {
  SimulationSettings settings;
  settings.dt = 1e-5;
  return settings;
}

// A voltage input; the coast-down and PID experiments and the classic estimators of Ganesh
// et al. (2012) are this model's; current and speed observed.
ModelTraits DcServoModel::traits() const {
  ModelTraits traits;
  traits.coast_down_and_pid = true;
  traits.classic_estimators = true;
  traits.default_observe = {"i", "w"};
  return traits;
}

SimStatus DcServoModel::SimulateReference(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const double Kt = values.Get("Kt"), J = values.Get("J"), B = values.Get("B");
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  const DriveEffects drive = DriveEffects::From(values, *request.effects);
  const internal::DcServoDiscretisation discrete =
      internal::DcServoDiscretisation::From(values, dt);
  const bool closed_loop = experiment.closed_loop;
  const bool has_coast = experiment.coast_off_time >= 0.0;

  std::vector<std::string> names = {"u", "i", "w", "theta"};
  if (closed_loop) names.emplace_back("r");
  internal::OutputSampler sampler(times, names);

  InputCursor input(experiment.input);
  const double t_start = times.front();
  double i = experiment.initial.i, w = experiment.initial.w, theta = experiment.initial.theta;
  internal::DcServoPid pid;
  const bool speed_loop = experiment.pid.loop == PidSettings::Loop::kSpeed;
  pid.derivative_state = speed_loop ? w : theta;
  const double alpha = dt / (experiment.pid.tau_d + dt);

  // The input over a step [t, t + dt) is read just after its midpoint (sim/input_read.h), so
  // that an event on the step grid (a step's t0, a switching instant, an `open` sample,
  // coast_off_time) takes effect at that grid point whatever the rounding of t = t_start + k dt;
  // an event between grid points takes effect at the nearest one, one on a midpoint at the
  // earlier one. The PID runs at t with the state at t.
  auto control = [&](double t, double* reference) {
    const double r = input.At(internal::InputReadTime(t, dt));
    *reference = r;
    return closed_loop ? pid.Control(experiment.pid, alpha, dt, r, speed_loop ? w : theta) : r;
  };

  double reference = 0.0;
  double u = control(t_start, &reference);
  std::array<double, 5> prev = {u, i + drive.i0, w, theta, reference};
  sampler.Record(t_start, prev.data(), t_start, prev.data());
  std::array<double, 5> now = prev;

  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  for (long step = 0; !sampler.done(); ++step) {
    // u: the voltage applied over [t, t_next), computed at t.
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_next = t_start + static_cast<double>(step + 1) * dt;
    const double t_mid = internal::InputReadTime(t, dt);
    const bool open = (has_coast && t_mid >= experiment.coast_off_time) || input.OpenAt(t_mid);
    const double effect_theta = effect_angle.At(t, theta);
    ReferenceStep(discrete, shaft, Kt, J, B, dt, open, u - drive.Vdt * Sign(i), effect_theta, &i,
                  &w, &theta);

    // Recorded with the state at t_next: the voltage applied from t_next on, so that the u
    // column of a closed-loop trace means what it means in open loop (the input from that
    // instant on) and replays as a recorded input.
    u = control(t_next, &reference);
    now = {u, i + drive.i0, w, theta, reference};
    if (!internal::AllFinite(now.data() + 1, 3, request.settings.divergence_limit)) {
      return {SimStatus::Code::kDiverged,
              internal::DivergedMessage(request.settings.divergence_limit), t_next};
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

double DcServoModel::DriveTorqueScale(const ParameterSet& values, double i_max, double /*u_max*/,
                                      double /*w_max*/) const {
  return values.Get("Kt") * i_max;
}

// At rest the armature current is u / R (no back-EMF): Kt / R per volt.
double DcServoModel::StallTorquePerInput(const ParameterSet& values) const {
  return std::abs(values.Get("Kt")) / values.Get("R");
}

// The armature and the shaft without effects (docs/model-dc-servo.md, "Linear part"):
// L di/dt = u - R i - Kb w, J dw/dt = Kt i - B w, dtheta/dt = w.
LinearModel DcServoModel::Linearise(const ParameterSet& values) const {
  const double R = values.Get("R"), L = values.Get("L"), Kt = values.Get("Kt"),
               Kb = values.Get("Kb"), J = values.Get("J"), B = values.Get("B");
  LinearModel model;
  model.available = true;
  model.input = "u (V)";
  model.assumption = "the effects (friction, load, cogging, dead time, ...) left out";
  model.states = {"i", "w", "theta"};
  model.outputs = model.states;
  model.A.resize(3, 3);
  model.A << -R / L, -Kb / L, 0.0, Kt / J, -B / J, 0.0, 0.0, 1.0, 0.0;
  model.B.resize(3, 1);
  model.B << 1.0 / L, 0.0, 0.0;
  model.C = Eigen::MatrixXd::Identity(3, 3);
  model.D = Eigen::MatrixXd::Zero(3, 1);
  return model;
}

}  // namespace blmd
