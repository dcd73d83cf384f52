// dc_servo's PID as a drive's digital controller (experiment.pid.sample_rate and delay,
// docs/model-dc-servo.md §6.1): sampled every 1/sample_rate, its output delayed by `delay`
// samples and held; without either key the PID runs on every simulation step as before.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/run.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

Config DigitalPid(double sample_rate, int delay) {
  Config config = LoadConfig(SourcePath("configs/ganesh-pid.json"));
  config.experiment.duration = 0.05;
  config.experiment.sample_rate = 1.0 / config.simulation.dt;  // every simulation step
  config.experiment.pid.sample_rate = sample_rate;
  config.experiment.pid.delay = delay;
  return config;
}

// At 1 kHz on a 10 us step the voltage holds for 100 steps and changes only on a controller
// sample; with a delay of one sample the first period is 0 V and the second the first
// sample's Kp e = 15 V (e = 1 rad, no integral or derivative yet); without delay the first
// period is 15 V.
TEST(DcServoDigitalPid, HeldBetweenSamplesAndDelayedBySamples) {
  for (const int delay : {0, 1, 2}) {
    const Config config = DigitalPid(1000.0, delay);
    const int every = static_cast<int>(std::lround(1.0 / (1000.0 * config.simulation.dt)));
    ASSERT_EQ(every, 100);
    Trace trace;
    ASSERT_TRUE(RunExperiment(config, &trace).ok());
    const auto& u = trace.Column("u");
    int changes_off_sample = 0;
    for (std::size_t k = 1; k < u.size(); ++k) {
      if (u[k] != u[k - 1] && k % every != 0) ++changes_off_sample;
    }
    EXPECT_EQ(changes_off_sample, 0) << "delay " << delay;
    for (int k = 0; k < delay * every; ++k) ASSERT_EQ(u[k], 0.0) << "delay " << delay;
    EXPECT_EQ(u[delay * every], 15.0) << "delay " << delay;
    EXPECT_EQ(u[delay * every + every - 1], 15.0) << "delay " << delay;
  }
}

// The rate and the delay are read from the config, the rate checked against the step; the
// PID without them keeps sample_rate 0 (every step).
TEST(DcServoDigitalPid, ConfigKeys) {
  const std::string base = Slurp(SourcePath("configs/ganesh-pid.json"));
  const auto with_pid = [&](const std::string& keys) {
    std::string text = base;
    const std::string anchor = "\"pid\": {";
    const std::size_t at = text.find(anchor);
    EXPECT_NE(at, std::string::npos);
    text.insert(at + anchor.size(), keys);
    return text;
  };
  const Config plain = ParseConfig(base, "ganesh-pid.json");
  EXPECT_EQ(plain.experiment.pid.sample_rate, 0.0);
  const Config digital =
      ParseConfig(with_pid("\"sample_rate\": 2000, \"delay\": 2,"), "ganesh-pid.json");
  EXPECT_EQ(digital.experiment.pid.sample_rate, 2000.0);
  EXPECT_EQ(digital.experiment.pid.delay, 2);
  const Config delayed = ParseConfig(with_pid("\"delay\": 3,"), "ganesh-pid.json");
  EXPECT_EQ(delayed.experiment.pid.sample_rate, 1.0 / delayed.simulation.dt);
  EXPECT_EQ(delayed.experiment.pid.delay, 3);
  try {
    ParseConfig(with_pid("\"sample_rate\": 3000,"), "ganesh-pid.json");
    ADD_FAILURE() << "a period of 33.3 steps was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("whole number of simulation steps"), std::string::npos)
        << error.what();
  }
}

// Sampled on every step without delay, the digital PID is the per-step PID, sample for
// sample.
TEST(DcServoDigitalPid, EveryStepWithoutDelayIsThePerStepPid) {
  Config per_step = DigitalPid(0.0, 1);
  Config digital = DigitalPid(1.0 / per_step.simulation.dt, 0);
  Trace a, b;
  ASSERT_TRUE(RunExperiment(per_step, &a).ok());
  ASSERT_TRUE(RunExperiment(digital, &b).ok());
  ASSERT_EQ(a.rows(), b.rows());
  double worst = 0.0;
  for (std::size_t k = 0; k < a.rows(); ++k) {
    worst = std::max(worst, std::abs(a.Column("theta")[k] - b.Column("theta")[k]));
  }
  EXPECT_LT(worst, 1e-12);
}

}  // namespace
}  // namespace blmd::testing
