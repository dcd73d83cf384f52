#include "blmd/sim/rigid_load/rigid_load.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "blmd/constants.h"
#include "blmd/sim/effects.h"
#include "sim/digital_cascade.h"
#include "sim/discretise.h"
#include "sim/input_read.h"
#include "sim/sampler.h"

namespace blmd {

// Typical values: a shaft of 0.02 kg·m² with 0.05 N·m·s/rad of damping (time constant
// J/B = 0.4 s) driven by its torque (Kt = 1), as tests/schema/rigid-truth.json.
const std::vector<ParamInfo>& RigidLoadModel::parameters() const {
  static const std::vector<ParamInfo> params = [] {
    std::vector<ParamInfo> list;
    ParamInfo J;
    J.name = "J";
    J.unit = "kg·m²";
    J.meaning = "inertia (a mass in kg for a linear axis)";
    J.default_lower = 1e-9;
    J.default_upper = 1e4;
    J.typical = 0.02;
    ParamInfo B;
    B.name = "B";
    B.unit = "N·m·s/rad";
    B.meaning = "viscous damping (N·s/m for a linear axis)";
    B.default_lower = 1e-12;
    B.default_upper = 1e5;
    B.typical = 0.05;
    ParamInfo Kt;
    Kt.name = "Kt";
    Kt.unit = "N·m per unit of u";
    Kt.meaning = "torque (force) per unit input: 1 when u is the torque itself";
    Kt.default_lower = 1e-6;
    Kt.default_upper = 1e6;
    Kt.optional = true;
    Kt.default_value = 1.0;
    Kt.typical = 1.0;
    list = {J, B, Kt};
    return list;
  }();
  return params;
}

SimulationSettings RigidLoadModel::default_settings() const {
  SimulationSettings settings;
  settings.dt = 1e-4;
  return settings;
}

// Driven by its torque: the equation error applies; the speed observed.
ModelTraits RigidLoadModel::traits() const {
  ModelTraits traits;
  traits.input_is_torque = true;
  traits.sampled_pid = true;
  traits.default_observe = {"w"};
  return traits;
}

namespace {

// The open-loop stepping both shafts share: from (w, theta) at the first sample, each step
// [t, t + dt) reads the input just after its midpoint (sim/input_read.h: events on the grid
// take effect there whatever the rounding of t, as in dc_servo) and `advance(t, u, &w, &theta)`
// moves the shaft, returning false when a state (its own hidden ones too) leaves the divergence
// limit; the samples are interpolated between steps and the u column is the input at each
// sample. `load` (two_mass): the load's speed and angle, which `advance` keeps current, written
// as the columns w_load and theta_load.
template <typename Advance>
SimStatus StepOpenLoop(const SimulationRequest& request, double w, double theta, Advance advance,
                       Trace* out, const std::array<double, 2>* load = nullptr) {
  const Experiment& experiment = *request.experiment;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  std::vector<std::string> names = {"u", "w", "theta"};
  if (load) names.insert(names.end(), {"w_load", "theta_load"});
  internal::OutputSampler sampler(times, names);
  InputCursor input(experiment.input);
  const double t_start = times.front();
  auto row = [&](double u) {
    return load ? std::array<double, 5>{u, w, theta, (*load)[0], (*load)[1]}
                : std::array<double, 5>{u, w, theta, 0.0, 0.0};
  };
  std::array<double, 5> prev = row(input.At(internal::InputReadTime(t_start, dt)));
  sampler.Record(t_start, prev.data(), t_start, prev.data());
  std::array<double, 5> now = prev;
  for (long step = 0; !sampler.done(); ++step) {
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_next = t_start + static_cast<double>(step + 1) * dt;
    const double u = input.At(internal::InputReadTime(t, dt));
    const bool finite = advance(t, u, &w, &theta);
    now = row(input.At(internal::InputReadTime(t_next, dt)));
    if (!finite || !internal::AllFinite(now.data() + 1, 2, request.settings.divergence_limit)) {
      return {SimStatus::Code::kDiverged,
              internal::DivergedMessage(request.settings.divergence_limit), t_next};
    }
    sampler.Record(t, prev.data(), t_next, now.data());
    prev = now;
  }
  sampler.Finish(out);
  auto& u_column = out->Column("u");
  // (a cursor: the sample times increase, so each read continues where the last stopped)
  InputCursor u_cursor(experiment.input);
  for (std::size_t k = 0; k < times.size(); ++k)
    u_column[k] = u_cursor.At(internal::InputReadTime(times[k], dt));
  return SimStatus::Ok();
}

// The shaft with a flexible coupling to its load (two_mass, docs/effects.md): the exact
// zero-order-hold step of x = [wm, theta_m, wl, delta], delta = theta_m - theta_l the twist,
//   Jm wm' = T - Bm wm - K delta - c (wm - wl),   Jl wl' = K delta + c (wm - wl) - Bl wl,
//   theta_m' = wm,   delta' = wm - wl,
// with T = Kt u - T_effects held over the step; the effects act on the motor at its speed and
// angle. Friction: at rest the motor sticks while static friction can balance what it feels
// (the drive, the positional effects and the shaft's torque); the load then swings on the held
// motor (its own exact two-state step). A step in which friction would reverse the motor ends
// with the motor at rest (the rigid model's interpolated stop is not made here).
SimStatus SimulateTwoMass(const SimulationRequest& request, const ShaftEffects& shaft, Trace* out) {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const double dt = request.settings.dt;
  const double J = values.Get("J"), B = values.Get("B"), Kt = values.Get("Kt");
  const TwoMassSides sides = shaft.Sides(J, B);
  const double Jm = sides.Jm, K = sides.K, c = sides.c;
  // x = [w, theta, w_load, delta]
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero(), Ad;
  sides.SetRows(0, 2, 3, &A);
  A(1, 0) = 1.0;
  Eigen::Matrix<double, 4, 1> Bin, Bd;
  Bin << 1.0 / Jm, 0.0, 0.0, 0.0;
  internal::Discretise<4, 1>(A, Bin, dt, &Ad, &Bd);
  const Eigen::Matrix2d A_held = sides.HeldLoad();  // [wl, delta] on a motor held at rest
  Eigen::Matrix2d Ad_held;
  Eigen::Matrix<double, 2, 1> none = Eigen::Matrix<double, 2, 1>::Zero(), unused;
  internal::Discretise<2, 1>(A_held, none, dt, &Ad_held, &unused);

  // The load starts as the initial state gives it (with the motor, the shaft untwisted, unless
  // set); its speed and angle, theta - delta, are written beside the motor's (a load-side
  // encoder).
  Eigen::Vector4d x(experiment.initial.w, experiment.initial.theta, experiment.initial.LoadSpeed(),
                    experiment.initial.twist);
  std::array<double, 2> load_side = {x(2), x(1) - x(3)};
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  const double limit = request.settings.divergence_limit;
  auto advance = [&](double t, double u, double* w, double* theta) {
    const double drive = Kt * u;
    const double wm = x(0), wl = x(2), twist = x(3);
    const double positional = shaft.NonFrictionTorque(effect_angle.At(t, x(1)));
    const double coupling = K * twist + c * (wm - wl);  // the shaft's torque on the motor
    bool stuck = false;
    const double friction =
        shaft.StepFriction(wm, drive - positional - shaft.DragTorque(wm) - coupling, &stuck);
    if (stuck) {
      const Eigen::Vector2d load = Ad_held * Eigen::Vector2d(wl, twist);
      x = Eigen::Vector4d(0.0, x(1), load(0), load(1));
    } else {
      x = Ad * x + Bd * (drive - friction - positional - shaft.DragTorque(wm));
      if (shaft.StopsWithin(wm, x(0))) x(0) = 0.0;
    }
    *w = x(0);
    *theta = x(1);
    load_side = {x(2), x(1) - x(3)};
    return internal::AllFinite(x.data(), 4, limit);
  };
  return StepOpenLoop(request, x(0), x(1), advance, out, &load_side);
}

}  // namespace

// The closed loop: the controller samples at its own rate and holds its output; the current
// (force) loop, a first-order lag, is a third state of the exact discretisation:
// x = [w, theta, u_a], u_a' = ω_b (u − u_a), the shaft driven by Kt u_a.
SimStatus RigidLoadModel::SimulateClosedLoop(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const PidSettings& pid = experiment.pid;
  const std::vector<double>& times = *request.sample_times;
  const double dt = request.settings.dt;
  const double J = values.Get("J"), B = values.Get("B"), Kt = values.Get("Kt");
  const double Ts = pid.sample_rate > 0.0 ? 1.0 / pid.sample_rate : dt;
  const long period = internal::ControllerPeriodSteps(pid, dt);
  if (period < 1) {
    return {SimStatus::Code::kInvalidParameters,
            "the controller's period is not a whole number of simulation steps", times.front()};
  }
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  const bool lag = pid.current_bandwidth > 0.0;
  const double wb = kTwoPi * pid.current_bandwidth;
  // x = [w, theta, u_a] and, on a two-mass shaft (two_mass, docs/effects.md), the load's
  // speed and the twist [w_l, delta]; inputs [u, T_effects] on the motor. Without the lag u_a
  // is u itself and its state stays 0.
  const bool flexible = shaft.two_mass();
  const int n = flexible ? 5 : 3;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd Bm = Eigen::MatrixXd::Zero(n, 2);
  const TwoMassSides sides = flexible ? shaft.Sides(J, B) : TwoMassSides{J, 0.0, 0.0, 0.0, B, 0.0};
  const double Jm = sides.Jm, K = sides.K, c = sides.c;
  if (flexible) {
    sides.SetRows(0, 3, 4, &A);
  } else {
    A(0, 0) = -B / J;
  }
  A(1, 0) = 1.0;
  Bm(0, 1) = -1.0 / Jm;
  if (lag) {
    A(0, 2) = Kt / Jm;
    A(2, 2) = -wb;
    Bm(2, 0) = wb;
  } else {
    Bm(0, 0) = Kt / Jm;
  }
  // Fixed sizes, so that the rigid shaft's steps stay those of its own 3-state discretisation.
  Eigen::Matrix3d Ad;
  Eigen::Matrix<double, 3, 2> Bd;
  Eigen::Matrix<double, 5, 5> Ad5;
  Eigen::Matrix<double, 5, 2> Bd5;
  if (flexible) {
    internal::Discretise<5, 2>(A, Bm, dt, &Ad5, &Bd5);
  } else {
    internal::Discretise<3, 2>(A, Bm, dt, &Ad, &Bd);
  }
  const double lag_decay = lag ? std::exp(-wb * dt) : 0.0;  // u_a while the shaft sticks
  // A held motor: the load swings on it (TwoMassSides::HeldLoad).
  Eigen::Matrix2d held = Eigen::Matrix2d::Identity();
  if (flexible) {
    held = (sides.HeldLoad() * dt).exp();
  }

  std::vector<std::string> names = {"u", "w", "theta", "r"};
  if (flexible) names.insert(names.end(), {"w_load", "theta_load"});  // a load-side encoder
  internal::OutputSampler sampler(times, names);
  InputCursor input(experiment.input);
  internal::DigitalCascade controller(pid, Ts);
  const double t_start = times.front();
  double w = experiment.initial.w, theta = experiment.initial.theta, u_a = 0.0;
  // A two-mass shaft's load: with the motor, untwisted, unless the initial state sets it.
  double w_load = experiment.initial.LoadSpeed(), twist = experiment.initial.twist;
  double reference = input.At(internal::InputReadTime(t_start, dt));
  double u = controller.Tick(reference, w, theta);
  std::array<double, 6> prev = {u, w, theta, reference, w_load, theta - twist};
  sampler.Record(t_start, prev.data(), t_start, prev.data());
  std::array<double, 6> now = prev;
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  for (long step = 0; !sampler.done(); ++step) {
    const double t = t_start + static_cast<double>(step) * dt;
    const double t_next = t_start + static_cast<double>(step + 1) * dt;
    const double drive = Kt * (lag ? u_a : u);
    // (the drag vanishes at rest: what the shaft feels once stopped is drive - positional)
    const double positional = shaft.NonFrictionTorque(effect_angle.At(t, theta));
    const double non_friction = positional + shaft.DragTorque(w);
    const double coupling = K * twist + c * (w - w_load);  // the load's torque on the motor
    bool stuck = false;
    const double friction = shaft.StepFriction(w, drive - non_friction - coupling, &stuck);
    const double w_old = w, theta_old = theta;
    if (stuck) {
      u_a = lag_decay * u_a + (1.0 - lag_decay) * u;
      if (flexible) {
        const Eigen::Vector2d load = held * Eigen::Vector2d(w_load, twist);
        w_load = load(0);
        twist = load(1);
      }
    } else if (flexible) {
      Eigen::Matrix<double, 5, 1> x;
      x << w, theta, u_a, w_load, twist;
      x = Ad5 * x + Bd5 * Eigen::Vector2d(u, friction + non_friction);
      w = shaft.StopsWithin(w_old, x(0)) ? 0.0 : x(0);
      theta = x(1);
      u_a = x(2);
      w_load = x(3);
      twist = x(4);
    } else {
      const Eigen::Vector3d x =
          Ad * Eigen::Vector3d(w, theta, u_a) + Bd * Eigen::Vector2d(u, friction + non_friction);
      w = x(0);
      theta = x(1);
      u_a = x(2);
      shaft.StopInStep(w_old, theta_old, dt, J, B, drive - positional, &w, &theta);
    }
    // The controller samples at t_next when it falls on its period; recorded with the state
    // at t_next: the command that holds from t_next on (as dc_servo's u column).
    if ((step + 1) % period == 0) {
      reference = input.At(internal::InputReadTime(t_next, dt));
      u = controller.Tick(reference, w, theta);
    }
    now = {u, w, theta, reference, w_load, theta - twist};
    const std::array<double, 2> load = {w_load, twist};
    if (!internal::AllFinite(now.data() + 1, 2, request.settings.divergence_limit) ||
        !internal::AllFinite(load.data(), 2, request.settings.divergence_limit)) {
      return {SimStatus::Code::kDiverged,
              internal::DivergedMessage(request.settings.divergence_limit), t_next};
    }
    sampler.Record(t, prev.data(), t_next, now.data());
    prev = now;
  }
  sampler.Finish(out);
  return SimStatus::Ok();
}

SimStatus RigidLoadModel::Simulate(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const double dt = request.settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  if (experiment.closed_loop) return SimulateClosedLoop(request, out);
  if (shaft.two_mass()) return SimulateTwoMass(request, shaft, out);
  const double J = values.Get("J"), B = values.Get("B"), Kt = values.Get("Kt");

  // x = [w, theta], input: the net torque Kt u - T_effects, held over the step.
  Eigen::Matrix2d A, Ad;
  A << -B / J, 0.0, 1.0, 0.0;
  Eigen::Matrix<double, 2, 1> Bm, Bd;
  Bm << 1.0 / J, 0.0;
  internal::Discretise<2, 1>(A, Bm, dt, &Ad, &Bd);

  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  auto advance = [&](double t, double u, double* w, double* theta) {
    const double drive = Kt * u;
    // (the drag vanishes at rest: what the shaft feels once stopped is drive - positional)
    const double positional = shaft.NonFrictionTorque(effect_angle.At(t, *theta));
    const double non_friction = positional + shaft.DragTorque(*w);
    bool stuck = false;
    const double friction = shaft.StepFriction(*w, drive - non_friction, &stuck);
    const double w_old = *w, theta_old = *theta;
    if (!stuck) {
      const Eigen::Vector2d x =
          Ad * Eigen::Vector2d(*w, *theta) + Bd * (drive - friction - non_friction);
      *w = x(0);
      *theta = x(1);
      shaft.StopInStep(w_old, theta_old, dt, J, B, drive - positional, w, theta);
    }
    return true;
  };
  return StepOpenLoop(request, experiment.initial.w, experiment.initial.theta, advance, out);
}

double RigidLoadModel::DriveTorqueScale(const ParameterSet& values, double /*i_max*/, double u_max,
                                        double w_max) const {
  return std::max(values.Get("Kt") * u_max, values.Get("B") * w_max);
}

double RigidLoadModel::StallTorquePerInput(const ParameterSet& values) const {
  return std::abs(values.Get("Kt"));
}

// The shaft without effects (docs/model-rigid-load.md, "Linear part"):
// J dw/dt = Kt u - B w, dtheta/dt = w, or the two-mass shaft when the values hold one.
LinearModel RigidLoadModel::Linearise(const ParameterSet& values) const {
  LinearModel model;
  model.input = "u (N·m, or N for a linear axis, per Kt)";
  LinearShaft(values, values.Get("Kt"), &model);
  model.assumption = model.has_shaft ? "the two-mass shaft kept; the other effects (friction, "
                                       "load, cogging, ...) left out"
                                     : "the effects (friction, load, cogging, ...) left out";
  return model;
}

}  // namespace blmd
