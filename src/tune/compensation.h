// From an identified model into the drive (docs/export.md §6): the final model's feed-forward
// torque, term by term with each value's 95 % interval, and its forms for a firmware (a
// portable C99 header and source), for an open drive's configuration (ODrive) and for a
// simulator (MuJoCo). blmd-export writes them; the online tracker (inertia_tracker.h) starts
// from the same values.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/io/stored_report.h"

namespace blmd {

// One exported quantity: its value, unit and meaning, and its 95 % interval when the report
// gives one (a parameter that was fitted), else the value is the config's (fixed).
struct ExportedValue {
  double value = 0.0;
  bool in_model = false;  // the final model has this parameter (else the value is 0)
  bool fitted = false;
  bool has_interval = false;
  double low = 0.0, high = 0.0;
  std::string unit, meaning;
};

// The final model's feed-forward torque, T_ff = the torque the drive must add so that the
// shaft follows a motion (theta, w, a) (the model's equation of motion solved for the drive
// torque, docs/effects.md):
//   T_ff = J a + B w + dB |w| + Cd w |w| + (Tc + Ts exp(-(w/ws)^2)) sgn(w) + TL
//          + Tcog sin(periods theta + phase) + K (theta - theta0) + Tg sin(theta + gravity_phase)
// Terms the model lacks are 0. N·m (a linear axis: N, with m, m/s, m/s²).
struct Compensation {
  std::string model, config_name, report_path, report_sha256;
  bool linear_axis = false;
  // The drive's input per unit of torque: u = T / torque_per_input (rigid_load's Kt, in N·m per
  // unit of u; dc_servo's Kt, N·m/A: the current). 0 when the model states none (blmd).
  double torque_per_input = 0.0;
  std::string input_unit;  // "A" (dc_servo: the armature current) or "u" (rigid_load)
  // Where the drive torque is read from a record: "u" (the input is the torque command, held
  // between samples), a measured current column (dc_servo's "i"), or "" (none).
  std::string torque_column;
  bool torque_is_command = false;
  // Every parameter of T_ff by its flat name (J, B, dB, Cd, Tc, Ts, ws, TL, Tcog, periods,
  // phase, K, theta0, Tg, gravity_phase), present or 0.
  std::map<std::string, ExportedValue> values;

  double Value(const std::string& name) const;
  // The same values as plain numbers, which the per-sample terms below read (a firmware's and
  // a tracker's loop evaluates them every sample): set by FromReport, and by Refresh() after
  // `values` is changed by hand.
  struct Numbers {
    double J = 0, B = 0, dB = 0, Cd = 0, Tc = 0, Ts = 0, ws = 0, TL = 0, Tcog = 0, periods = 0,
           phase = 0, K = 0, theta0 = 0, Tg = 0, gravity_phase = 0;
  } numbers;
  void Refresh();
  // The terms of T_ff (N·m) at an angle theta (rad), speed w (rad/s), acceleration a (rad/s²).
  double Inertia(double a) const;
  double Viscous(double w) const;   // B w + dB |w| + Cd w |w|
  double Friction(double w) const;  // (Tc + Ts exp(-(w/ws)^2)) sgn(w), sgn(0) = 0
  double Load() const;
  double Cogging(double theta) const;
  double Spring(double theta) const;
  double Gravity(double theta) const;
  double Torque(double theta, double w, double a) const;  // their sum

  // The report's final model on `config` (ApplyFinalModel) with the intervals of its fitted
  // parameters. InputError for a report of another model, or a final model this export cannot
  // write (an effect that is not a torque on the shaft: two_mass, dead_time and current_offset
  // are named).
  static Compensation FromReport(Config config, const StoredReport& report);
};

// The C99 files (blmd_compensation.h and .c): no allocation, <math.h> only, the floating type
// chosen by the macro BLMD_REAL (double by default); one function per term, their sum, the
// drive input it takes, and the cogging both as a table of `cogging_points` points per
// revolution (linear interpolation) and as its harmonic. Each constant carries its 95 %
// interval in a comment.
struct CFiles {
  std::string header, source;
};
CFiles CompensationC(const Compensation& compensation, int cogging_points);

// ODrive (firmware 0.5.x) settings as JSON: controller.config.inertia in N·m/(turn/s²) (= 2 pi J),
// the anti-cogging map of 3600 torques (N·m) per turn, what the firmware does with them, and
// the terms ODrive has no setting for (to be sent as input_torque from the host).
std::string ODriveSettings(const Compensation& compensation);

// A MuJoCo (MJCF) model of the shaft as a hinge joint: armature = J, damping = B,
// frictionloss = Tc (+ Ts: the breakaway), stiffness and springref for a spring; the terms MJCF
// joints cannot express are named in a comment.
std::string MujocoModel(const Compensation& compensation);

}  // namespace blmd
