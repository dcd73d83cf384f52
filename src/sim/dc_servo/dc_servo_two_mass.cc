// dc_servo with a flexible coupling (two_mass, docs/effects.md; docs/model-dc-servo.md,
// "A two-mass shaft"): the armature drives the motor's inertia, a shaft of stiffness K and
// damping c couples it to the load. The linear part, x = [i, w, theta, w_load, twist],
//   L di/dt       = u − R i − Kb w
//   Jm dw/dt      = Kt i − Bm w − K twist − c (w − w_load) − T_effects
//   dtheta/dt     = w
//   Jl dw_load/dt = K twist + c (w − w_load) − Bl w_load
//   dtwist/dt     = w − w_load
// with Jm = J/(1+r), Jl = J r/(1+r), K = Jl (2π fa)², c = 2 ζ Jl 2π fa, Bl = s B, Bm = B − Bl,
// is advanced exactly over each step with the input and the effects' torques held (as the
// rigid shaft, docs/model-dc-servo.md, "Exact discretisation"). The effects act on the motor,
// which carries the encoder; a motor held by friction lets the load swing on the shaft, and an
// open armature (coast-down, an `open` sample) carries no current.
#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

#include "blmd/constants.h"
#include "blmd/sim/dc_servo/dc_servo.h"
#include "blmd/sim/effects.h"
#include "sim/dc_servo/dc_servo_steps.h"
#include "sim/discretise.h"
#include "sim/input_read.h"
#include "sim/sampler.h"

namespace blmd {

SimStatus DcServoModel::SimulateTwoMass(const SimulationRequest& request, Trace* out) const {
  const ParameterSet& values = *request.parameters;
  const Experiment& experiment = *request.experiment;
  const double dt = request.settings.dt;
  const double R = values.Get("R"), L = values.Get("L"), Kt = values.Get("Kt"),
               Kb = values.Get("Kb"), J = values.Get("J"), B = values.Get("B");
  const ShaftEffects shaft =
      ShaftEffects::From(values, *request.effects, request.settings.friction_smoothing_w);
  const DriveEffects drive = DriveEffects::From(values, *request.effects);
  const TwoMassSides sides = shaft.Sides(J, B);
  const double Jm = sides.Jm, K = sides.K, c = sides.c;

  // Closed armature: x = [i, w, theta, w_load, twist], inputs [u_eff, T_effects].
  Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Zero();
  A(0, 0) = -R / L;
  A(0, 1) = -Kb / L;
  A(1, 0) = Kt / Jm;
  sides.SetRows(1, 3, 4, &A);
  A(2, 1) = 1.0;
  Eigen::Matrix<double, 5, 2> Bin = Eigen::Matrix<double, 5, 2>::Zero();
  Bin(0, 0) = 1.0 / L;
  Bin(1, 1) = -1.0 / Jm;
  Eigen::Matrix<double, 5, 5> Ad;
  Eigen::Matrix<double, 5, 2> Bd;
  internal::Discretise<5, 2>(A, Bin, dt, &Ad, &Bd);
  // Open armature (i = 0): x = [w, theta, w_load, twist], input T_effects.
  const Eigen::Matrix4d Ao = A.bottomRightCorner<4, 4>();
  const Eigen::Matrix<double, 4, 1> Bo = Bin.bottomRightCorner<4, 1>();
  Eigen::Matrix4d Ado;
  Eigen::Matrix<double, 4, 1> Bdo;
  internal::Discretise<4, 1>(Ao, Bo, dt, &Ado, &Bdo);
  // The motor held at rest: the current alone, and the load swinging on the shaft,
  // [w_load, twist]' = [[-(c + Bl)/Jl, K/Jl], [-1, 0]] [w_load, twist].
  const internal::DcServoDiscretisation rigid = internal::DcServoDiscretisation::From(values, dt);
  const Eigen::Matrix2d held = (sides.HeldLoad() * dt).exp();

  const double limit = request.settings.divergence_limit;
  double w_load = experiment.initial.LoadSpeed(), twist = experiment.initial.twist;
  // Its speed and angle, theta - twist, written beside the motor's (a load-side encoder).
  std::array<double, 2> load_side = {w_load, experiment.initial.theta - twist};
  EffectAngle effect_angle(request.sample_times, request.settings.effect_angle);
  auto advance = [&](double t, bool open, double u_eff, double* i, double* w, double* theta) {
    const double positional = shaft.NonFrictionTorque(effect_angle.At(t, *theta));
    const double non_friction = positional + shaft.DragTorque(*w);
    const double coupling = K * twist + c * (*w - w_load);  // the load's torque on the motor
    bool stuck = false;
    const double friction =
        shaft.StepFriction(*w, (open ? 0.0 : Kt * *i) - non_friction - coupling, &stuck);
    const double w_old = *w;
    if (stuck) {
      *i = open ? 0.0 : rigid.Ads(0, 0) * *i + rigid.Bds(0, 0) * u_eff;
      const Eigen::Vector2d load = held * Eigen::Vector2d(w_load, twist);
      w_load = load(0);
      twist = load(1);
    } else if (open) {
      *i = 0.0;
      const Eigen::Vector4d x =
          Ado * Eigen::Vector4d(*w, *theta, w_load, twist) + Bdo * (friction + non_friction);
      *w = shaft.StopsWithin(w_old, x(0)) ? 0.0 : x(0);
      *theta = x(1);
      w_load = x(2);
      twist = x(3);
    } else {
      Eigen::Matrix<double, 5, 1> x;
      x << *i, *w, *theta, w_load, twist;
      x = Ad * x + Bd * Eigen::Vector2d(u_eff, friction + non_friction);
      *i = x(0);
      *w = shaft.StopsWithin(w_old, x(1)) ? 0.0 : x(1);
      *theta = x(2);
      w_load = x(3);
      twist = x(4);
    }
    load_side = {w_load, *theta - twist};
    const std::array<double, 2> load = {w_load, twist};
    return internal::AllFinite(load.data(), 2, limit);
  };
  return internal::RunDcServoSteps(request, drive, advance, out, &load_side);
}

}  // namespace blmd
