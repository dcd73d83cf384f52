// The simulators' fast paths against their reference paths (docs/performance.md): every
// output column of Simulate() within 1e-9 of SimulateReference(), relative to the column's
// largest magnitude, for both models over several configs, numerics and effects. The
// measured worst deviation is printed and recorded.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "blmd/run.h"
#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/dc_servo/dc_servo.h"
#include "support/fast_reference.h"
#include "support/test_support.h"

namespace blmd {
namespace {

constexpr double kTolerance = 1e-9;

Config Load(const std::string& name) { return LoadConfig(testing::SourcePath("configs/" + name)); }

using Runs = testing::FastAndReference;

template <typename ModelT>
Runs RunBoth(const Config& config) {
  return testing::RunFastAndReference<ModelT>(config);
}

template <typename ModelT>
void ExpectFastMatchesReference(const std::string& label, const Config& config) {
  const Runs runs = RunBoth<ModelT>(config);
  ASSERT_TRUE(runs.reference_status.ok()) << runs.reference_status.message;
  ASSERT_TRUE(runs.fast_status.ok()) << runs.fast_status.message;
  std::string where;
  const double worst = testing::WorstRelativeDeviation(runs.fast, runs.reference, &where);
  std::printf("[ measured ] %s: worst relative deviation %.3g (column %s), %zu rows\n",
              label.c_str(), worst, where.c_str(), runs.reference.rows());
  ::testing::Test::RecordProperty(label, std::to_string(worst));
  EXPECT_LT(worst, kTolerance) << label << ", column " << where;
}

void AddEffect(Config* config, const std::string& name,
               const std::vector<std::pair<std::string, double>>& parameters) {
  config->effects.push_back(name);
  for (const auto& [key, value] : parameters) config->parameters.Set(key, value);
}

// ---- blmd ----

TEST(FastPath, BlmdBundledStep) {
  ExpectFastMatchesReference<BlmdDriveModel>("blmd 1 V step", Load("blmd-d31x.json"));
}

TEST(FastPath, BlmdWithoutRegulaFalsiWithDiagnostics) {
  Config config = Load("blmd-d31x.json");
  config.simulation.regula_falsi = false;
  config.simulation.diagnostics = true;
  ExpectFastMatchesReference<BlmdDriveModel>("blmd no regula falsi", config);
}

TEST(FastPath, BlmdWithoutBlanking) {
  Config config = Load("blmd-d31x.json");
  config.parameters.Set("delta", 0.0);
  ExpectFastMatchesReference<BlmdDriveModel>("blmd delta = 0", config);
}

TEST(FastPath, BlmdSquareDemandWithEveryShaftEffectAndDiagnostics) {
  Config config = Load("blmd-d31x-square.json");
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.05}});
  AddEffect(&config, "stribeck", {{"Ts", 0.03}, {"ws", 2.0}});
  AddEffect(&config, "load_torque", {{"TL", 0.1}});
  AddEffect(&config, "quadratic_drag", {{"Cd", 1e-5}});
  AddEffect(&config, "cogging", {{"Tcog", 0.05}, {"periods", 36.0}, {"phase", 0.4}});
  AddEffect(&config, "current_offset", {{"i0", 0.02}});
  config.simulation.diagnostics = true;
  ExpectFastMatchesReference<BlmdDriveModel>("blmd square + effects", config);
}

TEST(FastPath, BlmdLeadLagOffGridSamplesSmoothFriction) {
  Config config = Load("blmd-d31x.json");
  config.parameters.Set("Tz", 1e-4);
  config.parameters.Set("Tp", 2e-5);
  config.parameters.Set("Tpwm", 100e-6);
  config.parameters.Set("delta", 5e-6);
  config.experiment.sample_rate = 30000.0;  // 33.3 µs: samples between steps, interpolated
  config.experiment.duration = 0.08;
  config.experiment.input.amplitude = 2.5;
  config.experiment.initial.w = -20.0;
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.1}});
  config.simulation.friction_smoothing_w = 0.5;
  ExpectFastMatchesReference<BlmdDriveModel>("blmd lead-lag, 30 kHz, smooth friction", config);
}

TEST(FastPath, BlmdStickingAndStopping) {
  // A small demand against stiction: the shaft sticks, breaks away, and stops again.
  Config config = Load("blmd-d31x-square.json");
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.6}});
  config.experiment.input.amplitude = 1.0;
  config.simulation.diagnostics = true;
  ExpectFastMatchesReference<BlmdDriveModel>("blmd stick-slip", config);
}

// ---- dc_servo ----

TEST(FastPath, DcServoNoLoadStep) {
  ExpectFastMatchesReference<DcServoModel>("dc_servo no-load step", Load("ganesh-noload.json"));
}

TEST(FastPath, DcServoCoastDownWithFrictionAndDeadTime) {
  Config config = Load("ganesh-coastdown.json");
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.004}});
  AddEffect(&config, "dead_time", {{"Vdt", 0.6}});
  AddEffect(&config, "current_offset", {{"i0", 0.04}});
  ExpectFastMatchesReference<DcServoModel>("dc_servo coast-down + effects", config);
}

TEST(FastPath, DcServoSquareWithEveryShaftEffect) {
  Config config = Load("ganesh-square.json");
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.012}});
  AddEffect(&config, "stribeck", {{"Ts", 0.02}, {"ws", 50.0}});
  AddEffect(&config, "load_torque", {{"TL", 0.0015}});
  AddEffect(&config, "quadratic_drag", {{"Cd", 3e-7}});
  AddEffect(&config, "cogging", {{"Tcog", 0.025}, {"periods", 6.0}, {"phase", 0.5}});
  ExpectFastMatchesReference<DcServoModel>("dc_servo square + effects", config);
}

// Linear and open loop: the fast path takes macro steps (powers of the step matrix) between
// the samples and the square wave's edges (InputCursor::NextChange of a square wave).
TEST(FastPath, DcServoLinearSquareWaveInMacroSteps) {
  Config config = Load("ganesh-square.json");
  config.effects.clear();
  ExpectFastMatchesReference<DcServoModel>("dc_servo square, linear", config);
  config.experiment.sample_rate = 1234.5;  // samples off the step grid
  config.experiment.input.t0 = 0.0123;     // edges off the step grid
  ExpectFastMatchesReference<DcServoModel>("dc_servo square, linear, off-grid", config);
}

// Coulomb friction alone: macro steps while the shaft turns one way (w provably keeps its
// sign), single steps around each reversal, where the shaft stops, sticks and breaks away.
TEST(FastPath, DcServoCoulombFrictionInMacroSteps) {
  Config config = Load("ganesh-square.json");
  config.effects.clear();
  AddEffect(&config, "coulomb_friction", {{"Tc", 0.012}});
  AddEffect(&config, "load_torque", {{"TL", 0.002}});
  AddEffect(&config, "current_offset", {{"i0", 0.03}});
  ExpectFastMatchesReference<DcServoModel>("dc_servo square, Coulomb + load", config);
  config.experiment.sample_rate = 1234.5;  // samples off the step grid
  config.experiment.input.t0 = 0.0123;     // edges off the step grid
  ExpectFastMatchesReference<DcServoModel>("dc_servo square, Coulomb, off-grid", config);
  // 16 V: 0.051 N m of stall torque against Tc = 0.045: after each reversal the shaft
  // stops, sticks while the current builds up (L/R = 22 ms), then breaks away.
  config.parameters.Set("Tc", 0.045);
  config.experiment.input.amplitude = 16.0;
  ExpectFastMatchesReference<DcServoModel>("dc_servo square, Coulomb, sticking", config);
}

TEST(FastPath, DcServoClosedLoopPidAndStaircase) {
  ExpectFastMatchesReference<DcServoModel>("dc_servo PID", Load("ganesh-pid.json"));
  Config speed = Load("ganesh-pid.json");  // the speed loop: the PID measures w
  speed.experiment.pid = {PidSettings::Loop::kSpeed, 0.2, 3.0, 0.001, 2e-3, 24.0};
  speed.experiment.input.amplitude = 80.0;
  ExpectFastMatchesReference<DcServoModel>("dc_servo speed-loop PID", speed);
  Config digital = Load("ganesh-pid.json");  // a drive's digital PID: 1 kHz, two samples late
  digital.experiment.pid.sample_rate = 1000.0;
  digital.experiment.pid.delay = 2;
  ExpectFastMatchesReference<DcServoModel>("dc_servo digital PID", digital);
  Config staircase = Load("ganesh-staircase.json");
  staircase.experiment.sample_rate = 3000.0;  // samples between steps, interpolated
  ExpectFastMatchesReference<DcServoModel>("dc_servo staircase, 3 kHz", staircase);
}

TEST(FastPath, DcServoRecordedInputWithOpenColumn) {
  Config config = Load("ganesh-coastdown.json");
  Trace recorded;
  ASSERT_TRUE(RunExperiment(config, &recorded).ok());
  config.experiment.input.kind = InputSignal::Kind::kRecorded;
  config.experiment.input.times = recorded.Column("t");
  config.experiment.input.values = recorded.Column("u");
  config.experiment.input.open = recorded.Column("open");
  config.experiment.coast_off_time = -1.0;
  ExpectFastMatchesReference<DcServoModel>("dc_servo recorded u + open", config);
}

// The reference itself is not chaotic (docs/model-blmd.md §5): a 1e-12 relative change of J
// moves the 1 V step's outputs by far less than the tolerance above.
TEST(FastPath, BlmdReferenceIsLipschitzInTheParameters) {
  Config config = Load("blmd-d31x.json");
  Config nudged = config;
  nudged.parameters.Set("J", config.parameters.Get("J") * (1.0 + 1e-12));
  const Runs a = RunBoth<BlmdDriveModel>(config), b = RunBoth<BlmdDriveModel>(nudged);
  std::string where;
  const double worst = testing::WorstRelativeDeviation(b.reference, a.reference, &where);
  std::printf("[ measured ] J * (1 + 1e-12): reference outputs move by %.3g (column %s)\n", worst,
              where.c_str());
  EXPECT_LT(worst, 1e-9);
}

}  // namespace
}  // namespace blmd
