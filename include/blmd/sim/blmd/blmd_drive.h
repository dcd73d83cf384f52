// Three-phase brushless motor drive (BLMD) of Guinee & Lyden (1999) in torque-control
// mode, docs/model-blmd.md. Y-connected PM motor, p pole pairs, round rotor, linear magnetics.
//
//   lambda_j = Ls i_j + lambda_m sin(p theta - 2(j-1)pi/3),  j = 1..3 = a, b, c  (eqs. 2-3)
//   v_j = Rs i_j + Ls di_j/dt + e_j                                          (eqs. 4, 6)
//   e_j = Ke w cos(p theta - 2(j-1)pi/3),   Ke = p lambda_m                  (eq. 7)
//   Te  = Ke sum_j i_j cos(p theta - 2(j-1)pi/3)                             (eq. 5)
//   J dw/dt = Te - B w - T_effects,  dtheta/dt = w                           (eq. 8)
// Drive chain (Fig. 1): torque demand Td (V) -> i*_j = Kc Td cos(p theta - 2(j-1)pi/3) (V)
//   -> compensator on e_j = i*_j - Kf i_j: v_cj = Kp (1 + s Tz)/(1 + s Tp) e_j + Ki/s e_j
//      (PI when Tz = Tp = 0), clamped to +-Vtri with a conditional integrator;
//      Kf = Ki = 0 opens the current loop (v_cj = Kp Kc Td cos(...), open-loop voltage mode)
//   -> comparator against a symmetric triangular carrier (+-Vtri, period Tpwm, -Vtri at the
//      run's first sample time): upper switch commanded on while v_cj > v_tri    (eqs. 9-10)
//   -> every turn-on delayed by the blanking time delta (RC base-drive delay)  (eq. 11)
//   -> leg voltage v_jg = Ud if upper on, or both off and i_j < 0;
//                   v_jg = 0  if lower on, or both off and i_j >= 0           (eqs. 12-13)
//   -> v_sg = (v_1g + v_2g + v_3g)/3,  v_j = v_jg - v_sg                      (eq. 14)
//
// Numerics (paper §3): backward Euler for every sub-system at fixed dt (1 µs default);
// compensator output held over a step; one regula-falsi step (eq. 1) locates the PWM
// crossing inside a step (settings.regula_falsi), and the step applies the exact time
// average of the leg voltage given that crossing and the blanking; off, the comparator is
// sampled only at step boundaries. Tpwm/2 must be a multiple of dt, so the carrier is
// linear within a step (and regula falsi exact). While both switches of a leg are off, its
// diodes are decided at the step's end like every other sub-system: the upper one conducts
// if i_j ends the step negative, the lower one if positive, and if the current reaches zero
// the phase is open (both diodes block, the terminal floats, i_j stays 0 until a switch
// turns on). Phase currents start at zero (experiment.initial.i is not used).
// Input u = Td (V), read at each step's midpoint; the u column holds the demand applied
// from each sample on. Closed loop (experiment.pid): the drive's digital speed PI (or a
// position P over it, PidSettings) computes Td from the sampled w and theta; such a run
// takes the reference step loop whatever the method, and adds the column r (the reference).
// Outputs: t, u, i (phase-a current feedback, A, + i0), ib, ic (A), w (rad/s), theta (rad);
// settings.diagnostics adds va, vb, vc (phase voltages, the average over the step ending at the
// sample, V), Te (N·m, that step's torque) and vsg (neutral voltage against the DC bus's negative
// rail, step average, V).
#pragma once

#include "blmd/sim/model.h"

namespace blmd {

class BlmdDriveModel final : public Model {
 public:
  std::string_view name() const override { return "blmd"; }
  const std::vector<ParamInfo>& parameters() const override;
  std::vector<std::string> outputs() const override { return {"i", "ib", "ic", "w", "theta"}; }
  SimulationSettings default_settings() const override;
  ModelTraits traits() const override;
  std::string Validate(const ParameterSet& values,
                       const SimulationSettings& settings) const override;
  // The fast path (src/sim/blmd/blmd_drive_fast.cc): the same equations with the carrier's
  // settled stretches handled in closed form, the electrical angle's sine and cosine
  // advanced by rotation, and outputs written only at the sample steps.
  SimStatus Simulate(const SimulationRequest& request, Trace* out) const override;
  LinearModel Linearise(const ParameterSet& values) const override;
  // 1.5 Ke i_max: the motor torque at the largest phase current (the q-axis torque of
  // docs/model-blmd.md with the peak phase current as i_q).
  double DriveTorqueScale(const ParameterSet& values, double i_max, double u_max,
                          double w_max) const override;
  // The closed current loop i_j / (Kc Td cos) = Kf C G / (1 + Kf C G) / Kf per phase, with
  // C(s) = Kp (1 + s Tz)/(1 + s Tp) + Ki/s the compensator and G(s) = (Ud / 2 Vtri)/(Ls s + Rs)
  // the PWM's average gain into the winding (back-EMF a disturbance): its -3 dB frequency.
  double CurrentLoopBandwidthHz(const ParameterSet& values) const override;
  // Ud / (2 Ke): the speed whose back-EMF peak takes the whole linear range of the
  // sine-triangle PWM (phase voltage peak Ud/2), leaving none to drive the current.
  double SpeedLimit(const ParameterSet& values) const override;
  // The batched path (src/sim/blmd/blmd_drive_batch.cc): points of one experiment with a plain
  // shaft (no friction, drag or cogging) and one carrier period run 8 at a time in SIMD
  // lanes, each lane's outputs bit for bit Simulate()'s; other points run through Simulate().
  void SimulateBatch(const SimulationRequest* requests, std::size_t count, Trace* outs,
                     SimStatus* statuses) const override;
  // The reference path (src/sim/blmd/blmd_drive.cc): the straightforward step loop, kept as the
  // truth the fast path is tested against (tests/unit/fast_path_test.cc, 1e-9 relative).
  SimStatus SimulateReference(const SimulationRequest& request, Trace* out) const;
};

}  // namespace blmd
