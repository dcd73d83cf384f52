// Private helpers of the dc_servo model's steps (src/sim/dc_servo/dc_servo.cc;
// docs/model-dc-servo.md). The fast path (dc_servo_fast.cc) computes the same quantities in its own
// Simulate: split into these and its own steps, it ran the closed loop ~5 % slower
// (docs/architecture.md §6).
#pragma once

#include <Eigen/Dense>
#include <algorithm>

#include "blmd/sim/experiment.h"
#include "blmd/sim/parameters.h"
#include "sim/discretise.h"

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

}  // namespace blmd::internal
