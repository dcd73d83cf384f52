// DC servo of Ganesh et al. (2012), docs/model-dc-servo.md.
//
//   L di/dt     = u_eff - R i - Kb w        (armature; u_eff = u - Vdt sign(i))
//   J dw/dt     = Kt i - B w - T_effects    (rigid shaft + load; effects.h)
//   dtheta/dt   = w
//   theta(s)/u(s) = Kt / (s [(R + sL)(Js + B) + Kb Kt])          (Ganesh eq. 12)
//
// States i (A), w (rad/s), theta (rad). Input u: armature voltage (V), or in closed loop
// the position reference (rad) fed to a PID whose saturated output is the voltage.
// Outputs: t, u (applied voltage), i (measured: + i0), w, theta; closed loop adds r.
//
// Numerics: exact discretisation of the linear part over each step dt (matrix exponential
// of the augmented system, Eigen), with u and T_effects held over the step (zero-order
// hold). The input over a step [t, t + dt) is read at t + dt/2, so events on the step grid
// take effect exactly there. Coulomb/Stribeck friction sticks at rest (effects.h).
// Coast-down: with the armature open, i = 0 and only the mechanical sub-system evolves (its
// own exact step). The u column at a sample is the voltage applied from that instant on
// (closed loop too), so a trace replays through its u column.
#pragma once

#include "blmd/sim/model.h"

namespace blmd {

class DcServoModel final : public Model {
 public:
  std::string_view name() const override { return "dc_servo"; }
  const std::vector<ParamInfo>& parameters() const override;
  std::vector<std::string> outputs() const override { return {"i", "w", "theta"}; }
  SimulationSettings default_settings() const override;
  ModelTraits traits() const override;
  // The fast path (src/sim/dc_servo/dc_servo_fast.cc): the same exact discretisation unrolled into
  // scalar arithmetic, outputs written only at the sample steps.
  SimStatus Simulate(const SimulationRequest& request, Trace* out) const override;
  LinearModel Linearise(const ParameterSet& values) const override;
  // Kt i_max: the motor torque at the largest current.
  double DriveTorqueScale(const ParameterSet& values, double i_max, double u_max,
                          double w_max) const override;
  // At rest, u is the armature voltage: Kt / R.
  double StallTorquePerInput(const ParameterSet& values) const override;
  // The reference path (src/sim/dc_servo/dc_servo.cc): the straightforward step loop with Eigen's
  // matrices, kept as the truth the fast path is tested against (tests/unit/fast_path_test.cc).
  SimStatus SimulateReference(const SimulationRequest& request, Trace* out) const;

 private:
  // A flexible coupling (two_mass): the five-state step (src/sim/dc_servo/dc_servo_two_mass.cc),
  // which both paths take.
  SimStatus SimulateTwoMass(const SimulationRequest& request, Trace* out) const;
};

}  // namespace blmd
