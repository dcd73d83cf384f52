#include "blmd/sim/dc_servo/dc_servo.h"

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "blmd/constants.h"
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
  traits.torque_current_column = "i";
  traits.classic_estimators = true;
  traits.default_observe = {"i", "w"};
  return traits;
}

SimStatus DcServoModel::SimulateReference(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const double dt = request.settings.dt;
  if (SimStatus status = CheckRequest(request); !status.ok()) return status;

  const double Kt = values.Get("Kt"), J = values.Get("J"), B = values.Get("B");
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  if (shaft.two_mass()) return SimulateTwoMass(request, out);
  const DriveEffects drive = DriveEffects::From(values, *request.effects);
  const internal::DcServoDiscretisation discrete =
      internal::DcServoDiscretisation::From(values, dt);
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  auto advance = [&](double t, bool open, double u_eff, double* i, double* w, double* theta) {
    ReferenceStep(discrete, shaft, Kt, J, B, dt, open, u_eff, effect_angle.At(t, *theta), i, w,
                  theta);
    return true;
  };
  return internal::RunDcServoSteps(request, drive, advance, out);
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
  // A two-mass shaft (docs/effects.md) is linear: kept, as rigid_load keeps it, so that the
  // transfer functions, the Bode plot, the exports and a tuned loop see its resonance.
  if (values.Has("inertia_ratio") && values.Has("anti_resonance_hz")) {
    const TwoMassSides sides = TwoMassSides::Of(
        J, B, values.Get("inertia_ratio"), values.Get("anti_resonance_hz"),
        values.GetOr("shaft_damping_ratio", 0.0), values.GetOr("load_damping_share", 0.0));
    model.assumption =
        "the two-mass shaft kept; the other effects (friction, load, cogging, dead time, ...) "
        "left out";
    model.states = {"i", "w", "theta", "w_load", "twist"};
    model.outputs = {"i", "w", "theta"};
    // x = [i, w, theta, w_load, twist]
    model.A = Eigen::MatrixXd::Zero(5, 5);
    model.A(0, 0) = -R / L;
    model.A(0, 1) = -Kb / L;
    model.A(1, 0) = Kt / sides.Jm;
    sides.SetRows(1, 3, 4, &model.A);
    model.A(2, 1) = 1.0;
    model.B.resize(5, 1);
    model.B << 1.0 / L, 0.0, 0.0, 0.0, 0.0;
    model.C = Eigen::MatrixXd::Identity(3, 5);
    model.D = Eigen::MatrixXd::Zero(3, 1);
    return model;
  }
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
