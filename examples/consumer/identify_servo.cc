// Identifies J and B of a DC servo with the installed library: simulates the config's
// experiment (the truth), adds 1 % noise, fits J and B with Ceres from the config's start
// values, and prints the estimates with their 95 % intervals. Exit 0 when both lie within
// 2 % of the truth, 1 otherwise, 2 on bad input.
//   identify_servo CONFIG.json        (e.g. configs/ganesh-square.json)
#include <cmath>
#include <cstdio>
#include <exception>

#include "blmd/error.h"
#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "blmd/random.h"
#include "blmd/run.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: identify_servo CONFIG.json\n");
    return 2;
  }
  try {
    const blmd::Config config = blmd::LoadConfig(argv[1]);
    blmd::Trace trace;
    if (const blmd::SimStatus status = blmd::RunExperiment(config, &trace); !status.ok()) {
      std::fprintf(stderr, "simulation failed: %s\n", status.message.c_str());
      return 1;
    }
    blmd::Random random(7);
    for (const auto& column : config.identification.observe) {
      double peak = 0.0;
      for (double v : trace.Column(column)) peak = std::fmax(peak, std::fabs(v));
      for (double& v : trace.Column(column)) v += 0.01 * peak * random.Normal();
    }
    std::vector<blmd::FitTrace> traces;
    traces.push_back(blmd::RecordedFitTrace(std::move(trace), config.experiment.initial));
    const blmd::FitProblem problem(config, std::move(traces), config.identification.observe,
                                   blmd::MakeFreeParameters(config, config.identification.free));
    blmd::OptimizerOptions options;
    const blmd::FitResult fit = blmd::FindOptimizer("ceres").Minimize(problem, options);
    bool close = true;
    for (const auto& estimate : fit.estimates) {
      const double truth = config.parameters.Get(estimate.name);
      const double error = estimate.value / truth - 1.0;
      std::printf("%s = %.6g (95 %%: [%.6g, %.6g]), truth %.6g, error %+.3f %%\n",
                  estimate.name.c_str(), estimate.value, estimate.ci95_low, estimate.ci95_high,
                  truth, 100.0 * error);
      close = close && std::fabs(error) < 0.02;
    }
    return close ? 0 : 1;
  } catch (const blmd::InputError& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 2;
  }
}
