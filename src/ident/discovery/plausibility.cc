#include "ident/discovery/plausibility.h"

#include <algorithm>
#include <cmath>

#include "blmd/constants.h"
#include "blmd/format.h"
#include "blmd/sim/effects.h"
#include "ident/fit/rest_runs.h"

namespace blmd::internal {
namespace {

std::string G(double v, int digits = 4) { return FormatSignificant(v, digits); }

}  // namespace

// The trace's measured speed: its w column, else the central differences of `theta` (the
// measured angle, MeasuredAngle), the ends repeating their neighbours.
std::vector<double> MeasuredSpeed(const FitTrace& trace, const std::vector<double>& theta) {
  if (trace.trace.Has("w")) return trace.trace.Column("w");
  const auto& t = trace.trace.Column("t");
  const std::size_t n = theta.size();
  std::vector<double> w(n, 0.0);
  if (n < 3 || t.size() != n) return w;
  for (std::size_t k = 1; k + 1 < n; ++k)
    w[k] = (theta[k + 1] - theta[k - 1]) / (t[k + 1] - t[k - 1]);
  w[0] = w[1];
  w[n - 1] = w[n - 2];
  return w;
}

// The median fraction of a revolution the shaft turns between two samples in motion (the
// measured angle, else the integral of the measured speed: AngleNyquistOrder needs a recorded
// angle); samples with a step above a tenth of the largest count as in motion. 0 when it
// does not move.
double TurnsBetweenSamples(const FitProblem& problem) {
  std::vector<double> steps;
  for (const auto& trace : problem.traces()) {
    const std::vector<double> theta = MeasuredAngle(trace);
    double largest = 0.0;
    for (std::size_t k = 1; k < theta.size(); ++k)
      largest = std::max(largest, std::abs(theta[k] - theta[k - 1]));
    for (std::size_t k = 1; k < theta.size(); ++k) {
      const double step = std::abs(theta[k] - theta[k - 1]);
      if (std::isfinite(step) && step > 0.1 * largest) steps.push_back(step / kTwoPi);
    }
  }
  if (steps.empty()) return 0.0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

// The runs of at least 0.1 s and 20 samples over which the measured speed stays within 2 %
// of the record's top speed (a quantised angle's derivative dithers about zero there).
std::vector<StillRun> StandstillRuns(const FitProblem& problem, double w_max) {
  std::vector<StillRun> runs;
  const bool torque_input = problem.config().model->traits().input_is_torque;
  for (const auto& trace : problem.traces()) {
    if (!torque_input && !trace.trace.Has("i")) continue;
    const std::vector<double> theta = MeasuredAngle(trace);
    const auto& t = trace.trace.Column("t");
    const std::vector<double>& drive = trace.trace.Column(torque_input ? "u" : "i");
    if (theta.size() < 20 || t.size() != theta.size()) continue;
    const std::vector<double> w = MeasuredSpeed(trace, theta);
    for (const auto& [begin, end] : RestRuns(t, w, 0.02 * w_max)) {
      StillRun run;
      for (std::size_t j = begin; j < end; ++j) {
        run.theta += theta[j];
        run.drive += drive[j];
      }
      run.theta /= static_cast<double>(end - begin);
      run.drive /= static_cast<double>(end - begin);
      if (std::isfinite(run.theta) && std::isfinite(run.drive)) runs.push_back(run);
    }
  }
  return runs;
}

// Empty when the candidate's torque is held where the shaft rests; else why not. The static
// torque the drive leaves unheld by friction at each run, max(0, |T_drive - T_other| - Tc - Ts),
// is compared with and without the candidate: with it, its root mean square may exceed the
// one without by at most 5 % of the torque scale (the drive's noise and a friction's spread).
std::string HeldAtStandstill(const std::vector<StillRun>& runs, const ParameterSet& values,
                             const std::vector<std::string>& effects, const std::string& candidate,
                             bool torque_input, double torque_scale) {
  if (runs.empty()) return "";
  std::vector<std::string> all = effects;
  all.push_back(candidate);
  const ShaftEffects shaft = ShaftEffects::From(values, all, 0.0);
  const ShaftEffects alone = ShaftEffects::From(values, {candidate}, 0.0);
  const double Kt = values.Get("Kt");
  const double i0 = DriveEffects::From(values, effects).i0;
  const double holding = shaft.Tc + shaft.Ts;
  double with = 0.0, without = 0.0, largest = 0.0, largest_theta = 0.0;
  for (const StillRun& run : runs) {
    const double drive = torque_input ? Kt * run.drive : Kt * (run.drive - i0);
    const double own = alone.NonFrictionTorque(run.theta);
    const double other = shaft.NonFrictionTorque(run.theta) - own;
    const double unheld_with = std::max(0.0, std::abs(drive - other - own) - holding);
    const double unheld_without = std::max(0.0, std::abs(drive - other) - holding);
    with += unheld_with * unheld_with;
    without += unheld_without * unheld_without;
    if (std::abs(own) > std::abs(largest)) {
      largest = own;
      largest_theta = run.theta;
    }
  }
  const double count = static_cast<double>(runs.size());
  const double rms_with = std::sqrt(with / count), rms_without = std::sqrt(without / count);
  if (rms_with <= rms_without + 0.05 * torque_scale) return "";
  return "implausible: the shaft rests " + std::to_string(runs.size()) +
         (runs.size() == 1 ? " time" : " times") + " in the record, and there the drive does not " +
         "hold this torque (" + G(largest) + " N·m at " + G(largest_theta) +
         " rad; the torque the drive and friction leave unheld at rest would rise from " +
         G(rms_without) + " to " + G(rms_with) + " N·m RMS): no " + candidate +
         " acts on this shaft";
}

std::function<std::string(const ParameterSet&)> HeldAtStandstillCheck(
    const FitProblem& problem, double w_max, double torque_scale, const std::string& candidate) {
  const std::vector<StillRun> still = StandstillRuns(problem, w_max);
  const std::vector<std::string> effects = problem.config().effects;
  const bool torque_input = problem.config().model->traits().input_is_torque;
  return [still, effects, torque_input, torque_scale, candidate](const ParameterSet& p) {
    return HeldAtStandstill(still, p, effects, candidate, torque_input, torque_scale);
  };
}

}  // namespace blmd::internal
