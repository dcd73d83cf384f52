// The drive's digital speed (and position) controller of a closed-loop experiment
// (PidSettings, docs/tuning.md §7), shared by the models that run it: rigid_load (the shaft
// behind a current loop given as a lag) and blmd (the drive's own current loops and PWM).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "blmd/sim/experiment.h"

namespace blmd::internal {

// The drive's digital controller (PidSettings, docs/tuning.md §7): run every `period` steps,
// its output queued for `delay` samples and then held. The integrals are backward Euler sums
// (the sample's own error included), scaled by their gains; the speed integral is held while
// the output saturates in the direction of the error (conditional integration, Åström &
// Hägglund 1995, ch. 3, integrator windup): a position step that saturates the drive does not
// wind it up. The position integral (Ki of the position loop; blmd-tune leaves it 0) is not
// limited: its output, the speed reference, is not. A notch (pid.notch) filters the PI's
// output before the limit; the integral is held when the filtered command saturates.
class DigitalCascade {
 public:
  DigitalCascade(const PidSettings& pid, double Ts)
      : pid_(pid), Ts_(Ts), notch_(DiscreteNotch(pid.notch, Ts)) {
    queue_.assign(static_cast<std::size_t>(std::max(0, pid.delay)), 0.0);
  }

  // The command that takes effect now, for the reference r and the sampled w, theta.
  double Tick(double r, double w, double theta) {
    // The speed the controller feeds back: the measured one, or, as many drives and rigs
    // estimate it, the difference of the angle over speed_difference_samples samples.
    if (pid_.speed_difference_samples > 0) {
      const std::size_t n = static_cast<std::size_t>(pid_.speed_difference_samples);
      if (angles_.empty()) angles_.assign(n, theta);  // at rest before the first sample
      w = (theta - angles_[angle_at_]) / (static_cast<double>(n) * Ts_);
      angles_[angle_at_] = theta;
      angle_at_ = (angle_at_ + 1) % n;
    }
    const double low = pid_.LowerLimit(), high = pid_.u_max;
    double w_ref = r, kp = pid_.Kp, ki = pid_.Ki;
    if (pid_.loop == PidSettings::Loop::kPosition) {
      // The position P (and I): its output is the speed reference, not limited (the drive's
      // speed limit is the torque limit's consequence here).
      const double e = r - theta;
      position_integral_ += pid_.Ki * Ts_ * e;
      // The reference's rate (backward difference over one sample; 0 at the first) fed
      // forward into the speed reference: with speed_feedforward 1 and no speed integral the
      // cascade is the PD with a speed reference, speed_Kp Kp (r - theta) + speed_Kp (r' - w).
      const double rate = started_ ? (r - last_r_) / Ts_ : 0.0;
      last_r_ = r;
      started_ = true;
      w_ref = pid_.Kp * e + position_integral_ + pid_.speed_feedforward * rate;
      kp = pid_.speed_Kp;
      ki = pid_.speed_Ki;
    }
    const double e = w_ref - w;
    const double candidate = speed_integral_ + ki * Ts_ * e;
    const double u = notch_.Peek(kp * e + candidate);
    if (!((u > high && e > 0.0) || (u < low && e < 0.0))) speed_integral_ = candidate;
    const double command = std::clamp(notch_.Step(kp * e + speed_integral_), low, high);
    if (queue_.empty()) return command;
    const double out = queue_.front();
    queue_.erase(queue_.begin());
    queue_.push_back(command);
    return out;
  }

 private:
  const PidSettings& pid_;
  double Ts_;
  double speed_integral_ = 0.0;     // u
  double position_integral_ = 0.0;  // rad/s
  double last_r_ = 0.0;             // the position reference at the previous sample, rad
  std::vector<double> angles_;      // the last speed_difference_samples angles, a ring
  std::size_t angle_at_ = 0;        // the oldest of them
  bool started_ = false;
  BiquadRunner notch_;         // the identity without a notch
  std::vector<double> queue_;  // the commands computed, oldest first
};

// The controller's period in simulation steps dt (1/pid.sample_rate, every step when 0); 0
// when it is not a whole number of steps.
inline long ControllerPeriodSteps(const PidSettings& pid, double dt) {
  const double Ts = pid.sample_rate > 0.0 ? 1.0 / pid.sample_rate : dt;
  const long period = std::lround(Ts / dt);
  if (period < 1 || std::abs(static_cast<double>(period) * dt - Ts) > 1e-6 * Ts) return 0;
  return period;
}

}  // namespace blmd::internal
