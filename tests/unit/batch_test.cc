// The blmd model's batched path (BlmdDriveModel::SimulateBatch, docs/performance.md §5):
// every lane's outputs and status equal Simulate()'s bit for bit, under every instruction
// set this CPU offers, and stay within the fast path's 1e-9 of the reference path; the
// batch's bookkeeping (padding lanes, a lane that diverges, one that is invalid, one with
// friction, which leaves the lanes) changes nothing; FitProblem::EvaluateBatch and surfaces
// computed in batches equal their one-point-at-a-time results exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/surface.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/sim/blmd/blmd_drive.h"
#include "sim/blmd/blmd_batch.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using internal::BatchIsa;

Config Load(const std::string& name) { return LoadConfig(testing::SourcePath("configs/" + name)); }

const BlmdDriveModel& Blmd(const Config& config) {
  return dynamic_cast<const BlmdDriveModel&>(*config.model);
}

// Parameter points around the config's: J and B over +-40 %, every third one with another
// Kp and Ud as well, so that the lanes' PWM edges fall at different steps.
std::vector<ParameterSet> Points(const Config& config, int count) {
  std::vector<ParameterSet> points;
  for (int k = 0; k < count; ++k) {
    ParameterSet values = config.parameters;
    const double f = static_cast<double>(k) / std::max(1, count - 1);
    values.Set("J", config.parameters.Get("J") * (0.6 + 0.8 * f));
    values.Set("B", config.parameters.Get("B") * (1.4 - 0.8 * f));
    if (k % 3 == 2) {
      values.Set("Kp", config.parameters.Get("Kp") * 1.3);
      values.Set("Ud", config.parameters.Get("Ud") * 0.9);
    }
    points.push_back(values);
  }
  return points;
}

struct BatchRuns {
  std::vector<Trace> outs;
  std::vector<SimStatus> statuses;
};

BatchRuns RunBatch(const Config& config, const std::vector<ParameterSet>& points,
                   const std::vector<double>& times) {
  std::vector<SimulationRequest> requests(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    requests[k].parameters = &points[k];
    requests[k].effects = &config.effects;
    requests[k].experiment = &config.experiment;
    requests[k].settings = config.simulation;
    requests[k].sample_times = &times;
  }
  BatchRuns runs;
  runs.outs.resize(points.size());
  runs.statuses.resize(points.size());
  Blmd(config).SimulateBatch(requests.data(), requests.size(), runs.outs.data(),
                             runs.statuses.data());
  return runs;
}

SimStatus RunOne(const Config& config, const ParameterSet& values, const std::vector<double>& times,
                 Trace* out, bool reference = false) {
  SimulationRequest request;
  request.parameters = &values;
  request.effects = &config.effects;
  request.experiment = &config.experiment;
  request.settings = config.simulation;
  request.sample_times = &times;
  return reference ? Blmd(config).SimulateReference(request, out)
                   : Blmd(config).Simulate(request, out);
}

// Counts the values of `batch` that differ from `single` (bit for bit, -0 == +0).
std::size_t Differences(const Trace& batch, const Trace& single) {
  EXPECT_EQ(batch.names(), single.names());
  std::size_t differences = 0;
  for (const auto& name : single.names()) {
    const auto& a = batch.Column(name);
    const auto& b = single.Column(name);
    EXPECT_EQ(a.size(), b.size()) << name;
    for (std::size_t r = 0; r < std::min(a.size(), b.size()); ++r) differences += a[r] != b[r];
  }
  return differences;
}

std::vector<BatchIsa> SupportedIsas() {
  std::vector<BatchIsa> isas;
  for (BatchIsa isa :
       {BatchIsa::kScalar, BatchIsa::kBaseline, BatchIsa::kAvx2, BatchIsa::kAvx512}) {
    if (internal::CpuSupports(isa)) isas.push_back(isa);
  }
  return isas;
}

// Every lane of an 11-point batch (one full chunk of 8 and one of 3 with 5 padding lanes)
// against Simulate (bit for bit) and, for the first and last, SimulateReference (1e-9).
void ExpectLanesMatch(const std::string& label, const Config& config, int count = 11) {
  const std::vector<double> times = config.experiment.SampleTimes();
  const std::vector<ParameterSet> points = Points(config, count);
  std::vector<Trace> singles(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const SimStatus status = RunOne(config, points[k], times, &singles[k]);
    ASSERT_TRUE(status.ok()) << label << " point " << k << ": " << status.message;
  }
  const BatchIsa chosen = internal::ChosenBatchIsa();
  for (BatchIsa isa : SupportedIsas()) {
    ASSERT_TRUE(internal::ForceBatchIsa(isa));
    const BatchRuns runs = RunBatch(config, points, times);
    std::size_t differences = 0;
    for (std::size_t k = 0; k < points.size(); ++k) {
      ASSERT_TRUE(runs.statuses[k].ok())
          << label << " point " << k << ": " << runs.statuses[k].message;
      differences += Differences(runs.outs[k], singles[k]);
    }
    std::printf("[ measured ] %s, %s: %zu of %zu values differ from Simulate()\n", label.c_str(),
                internal::BatchIsaName(isa), differences,
                points.size() * singles[0].rows() * singles[0].names().size());
    EXPECT_EQ(differences, 0u) << label << ", " << internal::BatchIsaName(isa);
  }
  ASSERT_TRUE(internal::ForceBatchIsa(chosen));
  const BatchRuns runs = RunBatch(config, points, times);
  for (std::size_t k : {std::size_t{0}, points.size() - 1}) {
    Trace reference;
    ASSERT_TRUE(RunOne(config, points[k], times, &reference, true).ok());
    std::string column;
    const double worst = testing::WorstRelativeDeviation(runs.outs[k], reference, &column);
    std::printf("[ measured ] %s, point %zu: %.3g relative to the reference path\n", label.c_str(),
                k, worst);
    EXPECT_LT(worst, 1e-9) << label << " point " << k;
  }
}

TEST(BlmdBatch, ChoosesTheWidestInstructionSet) {
  const BatchIsa widest = SupportedIsas().back();
  std::printf("[ measured ] batched kernel: %s\n",
              internal::BatchIsaName(internal::ChosenBatchIsa()));
  if (std::getenv("BLMD_BATCH_ISA") == nullptr) {
    EXPECT_EQ(internal::ChosenBatchIsa(), widest);
  }
  EXPECT_TRUE(internal::CpuSupports(BatchIsa::kBaseline));
}

TEST(BlmdBatch, BundledStepLaneForLane) {
  Config config = Load("blmd-d31x.json");
  config.experiment.duration = 0.06;
  ExpectLanesMatch("blmd 1 V step", config);
}

TEST(BlmdBatch, WithoutRegulaFalsiWithDiagnostics) {
  Config config = Load("blmd-d31x.json");
  config.experiment.duration = 0.04;
  config.simulation.regula_falsi = false;
  config.simulation.diagnostics = true;
  ExpectLanesMatch("blmd no regula falsi, diagnostics", config);
}

TEST(BlmdBatch, WithoutBlankingAndWithLoadTorqueAndCurrentOffset) {
  Config config = Load("blmd-d31x-square.json");
  config.experiment.duration = 0.04;
  config.parameters.Set("delta", 0.0);
  config.effects = {"load_torque", "current_offset"};
  config.parameters.Set("TL", 0.1);
  config.parameters.Set("i0", 0.02);
  ExpectLanesMatch("blmd square, delta = 0, TL, i0", config);
}

TEST(BlmdBatch, LeadLagOffGridSamplesReversingShaft) {
  // The open phase (leg solver) is reached: the shaft reverses under a square demand.
  Config config = Load("blmd-d31x-square.json");
  config.parameters.Set("Tz", 1e-4);
  config.parameters.Set("Tp", 2e-5);
  config.parameters.Set("Tpwm", 100e-6);
  config.parameters.Set("delta", 5e-6);
  config.experiment.sample_rate = 30000.0;
  config.experiment.duration = 0.05;
  config.experiment.initial.w = -20.0;
  config.simulation.diagnostics = true;
  ExpectLanesMatch("blmd lead-lag, 30 kHz, square", config);
}

TEST(BlmdBatch, MixedBatchDivergingInvalidAndFrictionPoints) {
  // 10 points: lanes that reach a (low) divergence limit at different instants, one invalid
  // point, one with Coulomb friction (run by Simulate, outside the lanes), the rest normal.
  Config config = Load("blmd-d31x.json");
  config.experiment.duration = 0.05;
  config.simulation.divergence_limit = 60.0;  // rad/s: the light shafts get there
  config.effects = {"coulomb_friction"};
  config.parameters.Set("Tc", 0.0);
  const std::vector<double> times = config.experiment.SampleTimes();
  std::vector<ParameterSet> points = Points(config, 10);
  for (int k = 0; k < 4; ++k) points[k].Set("J", 2e-4 * (1.0 + 0.5 * k));  // diverge
  points[5].Set("J", -1.0);                                                // invalid
  points[7].Set("Tc", 0.02);                                               // not a plain shaft
  std::vector<Trace> singles(points.size());
  std::vector<SimStatus> single_statuses(points.size());
  int diverged = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    single_statuses[k] = RunOne(config, points[k], times, &singles[k]);
    diverged += single_statuses[k].code == SimStatus::Code::kDiverged;
  }
  ASSERT_EQ(diverged, 4);
  EXPECT_EQ(single_statuses[5].code, SimStatus::Code::kInvalidParameters);
  for (BatchIsa isa : SupportedIsas()) {
    ASSERT_TRUE(internal::ForceBatchIsa(isa));
    const BatchRuns runs = RunBatch(config, points, times);
    for (std::size_t k = 0; k < points.size(); ++k) {
      EXPECT_EQ(runs.statuses[k].code, single_statuses[k].code) << k;
      EXPECT_EQ(runs.statuses[k].message, single_statuses[k].message) << k;
      EXPECT_EQ(runs.statuses[k].at_time, single_statuses[k].at_time) << k;
      if (single_statuses[k].ok()) {
        EXPECT_EQ(Differences(runs.outs[k], singles[k]), 0u) << internal::BatchIsaName(isa) << k;
      }
    }
  }
  ASSERT_TRUE(internal::ForceBatchIsa(SupportedIsas().back()));
}

// FitProblem::EvaluateBatch and a surface computed 8 points at a time give exactly what one
// point at a time gives.
TEST(BlmdBatch, EvaluateBatchAndSurfaceEqualOnePointAtATime) {
  Config config = Load("blmd-d31x.json");
  TraceInputOptions input;
  input.select = {ParseRowSelection("t=0:0.04")};  // the first 40 ms: enough, and quick
  const FitTrace trace = LoadFitTrace(testing::SourcePath("testdata/blmd-d31x-step.csv"), input,
                                      config.experiment.initial);
  ASSERT_EQ(trace.trace.rows(), 2001u);
  const FitProblem problem(config, {trace}, {"i", "w"}, MakeFreeParameters(config, {"J", "B"}));
  std::vector<std::vector<double>> points;
  for (int k = 0; k < 11; ++k)
    points.push_back({1.19e-3 * (0.8 + 0.04 * k), 5e-4 * (1.2 - 0.04 * k)});
  points.push_back({std::nan(""), 5e-4});
  points.push_back({-1.0, 5e-4});
  const std::vector<Evaluation> batch = problem.EvaluateBatch(points);
  ASSERT_EQ(batch.size(), points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Evaluation single = problem.Evaluate(points[k]);
    EXPECT_EQ(batch[k].ok, single.ok) << k;
    EXPECT_EQ(batch[k].reason, single.reason) << k;
    EXPECT_EQ(batch[k].cost, single.cost) << k;
    EXPECT_EQ(batch[k].mse, single.mse) << k;
    EXPECT_EQ(batch[k].mse_per_trace, single.mse_per_trace) << k;
  }
  EXPECT_TRUE(batch[5].ok);
  EXPECT_FALSE(batch[11].ok);
  EXPECT_FALSE(batch[12].ok);

  const std::vector<GridAxis> axes = {ParseGridAxis("J=0.9e-3:1.5e-3:5"),
                                      ParseGridAxis("B=log:2e-4:1e-3:4")};
  SurfaceOptions one_at_a_time, batched;
  one_at_a_time.batch = 1;
  one_at_a_time.threads = batched.threads = 2;
  const auto a = ComputeSurface(problem, axes, one_at_a_time);
  const auto b = ComputeSurface(problem, axes, batched);
  ASSERT_EQ(a.size(), 20u);
  ASSERT_EQ(b.size(), 20u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].coordinates, b[k].coordinates) << k;
    EXPECT_EQ(a[k].evaluation.cost, b[k].evaluation.cost) << k;
  }
}

}  // namespace
}  // namespace blmd
