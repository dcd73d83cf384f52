// An online estimator of the inertia J and the load torque TL (docs/export.md §7), seeded by
// an identification report: recursive least squares with forgetting, in its Kalman-filter
// form (a random-walk parameter model; Ljung & Söderström, Theory and Practice of Recursive
// Identification, 1983, §2.6; Åström & Wittenmark, Adaptive Control, 2nd ed., 1995, §2.2), on
// the filtered equation of motion
//   F[T_drive - T_known(theta, w)] = J F[dw/dt] + TL
// where F is a second-order Butterworth state-variable filter (Tustin) of corner filter_hz,
// which gives the filtered acceleration without differentiating noise twice, T_drive the
// drive's torque (Kt u for rigid_load, Kt i for dc_servo) and T_known the report's other
// terms (viscous, friction, cogging, spring, gravity: compensation.h). J is updated only while
// the filtered acceleration exceeds `gate` times its noise (excitation gating: no update and
// no drift of J while the motion does not inform it); TL is updated on every sample. blmd-track
// runs it on a recorded trace; blmd-export --format c writes the same recursion as C.
#pragma once

#include <string>

#include "tune/compensation.h"

namespace blmd {

struct TrackerSettings {
  double filter_hz = 0.0;       // the state-variable filter's corner; 0: fs/50 within [1, 50] Hz
  double memory_s = 1.0;        // forgetting time constant of J over excited time, s
  double gate = 3.0;            // J updates where |filtered acceleration| > gate x its noise std
  double change_margin = 0.05;  // "changed": the 95 % interval beyond the offline one by this
  double speed_noise = 0.0;     // std of the measured speed, rad/s; 0: the report's (else 1 %
                                // of the trace's RMS speed, said by the caller)
};

// The speed noise the tracker gates on: the settings' when given, else the report's noise of
// w; `source` says which. 0 (source "") when neither gives one.
struct SpeedNoise {
  double sigma = 0.0;
  std::string source;
};
SpeedNoise SpeedNoiseOf(const TrackerSettings& settings, const StoredReport& report);

// The recursion's numbers, fixed at the start: what the C tracker is generated with.
struct TrackerSeed {
  double dt = 0.0;  // s, the sample period
  double filter_hz = 0.0;
  double lambda = 1.0;                 // forgetting factor per excited sample, exp(-dt / memory)
  double gate_acceleration = 0;        // rad/s², |a_f| above which J updates
  double noise_floor = 0.0;            // N·m², the least equation-noise variance (J sigma_a)^2
  double J = 0.0, J_variance = 0.0;    // the report's J and its variance (from its interval)
  double TL = 0.0, TL_variance = 0.0;  // the report's TL (0 when the model has none), its
                                       // variance (diffuse when not fitted)
  double J_low = 0.0, J_high = 0.0;    // the offline 95 % interval
  double change_margin = 0.05;
  double acceleration_noise_gain = 0.0;  // std of a_f per unit of white speed noise std
  // The filter's Tustin coefficients at this period (TrackerFilter): ad row-major, bd.
  double ad[4] = {0, 0, 0, 0}, bd[2] = {0, 0};
  // Samples after the first during which the filters settle from their start (ten time
  // constants of the filter's poles, 10 / (zeta wf dt)): nothing is updated.
  long warmup_samples = 0;
  // The drive torque is a command held between samples (rigid_load's u): the filter then takes
  // it as held over each period (exact for a zero-order hold) rather than as the trapezoid of
  // its samples, which would shift every step by half a period. A measured current (dc_servo's
  // i) is a sampled continuous signal: the trapezoid.
  bool drive_held = true;
};

// Builds the seed for a trace sampled every `dt` s with speed noise `speed_noise` (rad/s).
TrackerSeed MakeTrackerSeed(const Compensation& model, const TrackerSettings& settings, double dt,
                            double speed_noise);

class InertiaTracker {
 public:
  InertiaTracker(const Compensation& model, const TrackerSeed& seed);
  // One sample: the drive's torque (N·m), the measured speed (rad/s) and angle (rad).
  void Update(double drive_torque, double w, double theta);

  double J() const { return J_; }
  double J_low() const;  // 95 % interval of the current estimate
  double J_high() const;
  double TL() const { return TL_; }
  bool excited() const { return excited_; }  // the last sample updated J
  bool changed() const;  // the interval lies beyond the offline one by more than the margin
  double filtered_acceleration() const { return a_[1]; }

 private:
  const Compensation& model_;
  TrackerSeed seed_;
  // The filters run x_{k+1} = Ad x_k + bd v_mean with the seed's Ad, bd (TrackerFilter).
  // Filter states of w, of the drive torque and of the known torque.
  double a_[2] = {0, 0}, d_[2] = {0, 0}, k_[2] = {0, 0};
  double last_w_ = 0.0, last_d_ = 0.0, last_k_ = 0.0;
  bool started_ = false, excited_ = false;
  long samples_ = 0;
  double J_, TL_, p_[2][2], noise_;
};

// The filter's discrete coefficients: ad (2x2, row-major) and bd (2) for corner filter_hz at
// period dt; MakeTrackerSeed keeps them in the seed, which the tracker and the C generator
// both read, so that both run the same arithmetic.
void TrackerFilter(double filter_hz, double dt, double ad[4], double bd[2]);

// The C99 tracker (blmd_tracker.h and .c) seeded with `seed`; it calls blmd_compensation.h's
// terms for the known torque.
CFiles TrackerC(const TrackerSeed& seed);

}  // namespace blmd
