// The drive's digital cascade (src/sim/digital_cascade.h, docs/config.md experiment.pid): the
// speed feed-forward of the position reference's rate and the speed estimated from the angle.
#include "sim/digital_cascade.h"

#include <gtest/gtest.h>

#include <vector>

#include "blmd/sim/experiment.h"

namespace blmd {
namespace {

// A speed P of gain 1 with no delay at Ts = 1 s: the command is r - (the speed fed back).
// With speed_difference_samples 2 the speed is (theta_k - theta_{k-2}) / 2, the angle at rest
// before the first sample.
TEST(DigitalCascade, SpeedFromTheAngleOverNSamples) {
  PidSettings pid;
  pid.loop = PidSettings::Loop::kSpeed;
  pid.Kp = 1.0;
  pid.u_max = 100.0;
  pid.delay = 0;
  pid.speed_difference_samples = 2;
  internal::DigitalCascade cascade(pid, 1.0);
  const std::vector<double> theta = {0.0, 1.0, 3.0, 6.0, 10.0};
  const std::vector<double> speed = {0.0, 0.5, 1.5, 2.5, 3.5};
  for (std::size_t k = 0; k < theta.size(); ++k) {
    // The measured w (999) is not what is fed back.
    EXPECT_DOUBLE_EQ(cascade.Tick(0.0, 999.0, theta[k]), -speed[k]) << k;
  }
  pid.speed_difference_samples = 0;
  internal::DigitalCascade measured(pid, 1.0);
  EXPECT_DOUBLE_EQ(measured.Tick(0.0, 2.0, 5.0), -2.0);
}

// A position P over a speed P with the reference's rate fed forward: on a ramp the shaft
// follows exactly (theta = r, w = r') needs no command; without the feed-forward the command
// is -speed_Kp r'.
TEST(DigitalCascade, SpeedFeedForwardOfTheReferenceRate) {
  PidSettings pid;
  pid.loop = PidSettings::Loop::kPosition;
  pid.Kp = 50.0;
  pid.speed_Kp = 2.0;
  pid.u_max = 100.0;
  pid.delay = 0;
  const double Ts = 1e-3, rate = 3.0;
  for (const double feedforward : {0.0, 1.0}) {
    pid.speed_feedforward = feedforward;
    internal::DigitalCascade cascade(pid, Ts);
    double last = 0.0;
    for (int k = 0; k < 5; ++k) {
      const double r = rate * Ts * k;
      last = cascade.Tick(r, rate, r);
    }
    EXPECT_NEAR(last, -pid.speed_Kp * rate * (1.0 - feedforward), 1e-12) << feedforward;
  }
}

}  // namespace
}  // namespace blmd
