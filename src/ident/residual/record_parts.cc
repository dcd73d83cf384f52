#include "ident/residual/record_parts.h"

#include <algorithm>
#include <string>

#include "blmd/error.h"

namespace blmd::internal {
namespace {

constexpr std::size_t kMinimumRows = 50;

Trace Rows(const Trace& trace, std::size_t begin, std::size_t end) {
  Trace out;
  out.comments = trace.comments;
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    const auto& column = trace.Column(c);
    out.Append(trace.names()[c], std::vector<double>(column.begin() + static_cast<long>(begin),
                                                     column.begin() + static_cast<long>(end)));
  }
  return out;
}

// Each part must inform a fit on its own: a record whose motion lies in one half (a step at
// the middle of a short record, the shaft at rest before it) has a half whose observed
// columns are constant, and a fit of that half is no fit (FitProblem refuses it). Then the
// parts cannot judge anything, and the caller says so instead of failing the whole command.
RecordParts Checked(const FitProblem& problem, RecordParts parts) {
  for (const auto* part : {&parts.first, &parts.second}) {
    try {
      const FitProblem alone(problem.config(), *part, problem.observe(), problem.free());
    } catch (const InputError& error) {
      RecordParts refused;
      refused.description = parts.description;
      refused.reason =
          std::string("a part of the record cannot be fitted alone (") + error.what() + ")";
      return refused;
    }
  }
  return parts;
}

}  // namespace

RecordParts SplitRecord(const FitProblem& problem, const std::vector<double>& values) {
  RecordParts parts;
  const std::vector<FitTrace>& traces = problem.traces();
  if (traces.size() >= 2) {
    // Alternate traces: runs are often recorded in order of speed or direction, and each
    // part should span them (the first half against the second asked the model to
    // extrapolate: on the ODrive spin-ups the cross-validated NRMSE was 19 against 0.78 fitted).
    for (std::size_t k = 0; k < traces.size(); ++k) {
      (k % 2 == 0 ? parts.first : parts.second).push_back(traces[k]);
    }
    parts.description = "the odd and the even traces";
    parts.ok = true;
    return Checked(problem, std::move(parts));
  }
  if (traces.empty()) {
    parts.reason = "no trace";
    return parts;
  }
  const FitTrace& whole = traces.front();
  const std::size_t rows = whole.trace.rows();
  if (rows < 2 * kMinimumRows) {
    parts.reason = "the trace has too few samples to cut in two";
    return parts;
  }
  const std::size_t split = rows / 2;
  FitTrace first = whole;
  first.trace = Rows(whole.trace, 0, split);
  FitTrace second = whole;
  second.trace = Rows(whole.trace, split, rows);
  second.path = whole.path + " (second half)";
  first.path = whole.path + " (first half)";
  // The second half's initial state: the model's own at `values` (its simulation is a
  // smoothed estimate: a measured speed carries its noise into a slow mechanical transient,
  // which put K of a spring at 38 % of its value on one half), else measured.
  Trace simulated;
  const bool have_simulation = !problem.equation_error() &&
                               problem.Simulate(0, values, &simulated).ok() &&
                               simulated.rows() == rows;
  auto state = [&](const char* name, double fallback) {
    if (have_simulation && simulated.Has(name)) return simulated.Column(name)[split];
    if (whole.trace.Has(name)) return whole.trace.Column(name)[split];
    return fallback;
  };
  second.initial.i = state("i", whole.initial.i);
  second.initial.w = state("w", whole.initial.w);
  const std::vector<double> angle = MeasuredAngle(whole);
  second.initial.theta = have_simulation && simulated.Has("theta")
                             ? simulated.Column("theta")[split]
                             : (angle.empty() ? whole.initial.theta : angle[split]);
  // A two-mass shaft's load, a state no column of the record gives: where the simulation had
  // it at the cut (a load left with the motor and untwisted there keeps the momentum it lacks
  // for as long as J/B, seconds on a lightly damped shaft).
  if (have_simulation && simulated.Has("w_load") && simulated.Has("theta_load") &&
      simulated.Has("theta")) {
    second.initial.w_load = simulated.Column("w_load")[split];
    second.initial.twist = simulated.Column("theta")[split] - simulated.Column("theta_load")[split];
  }
  parts.first.push_back(std::move(first));
  parts.second.push_back(std::move(second));
  parts.description = "the two halves of the trace";
  parts.ok = true;
  return Checked(problem, std::move(parts));
}

}  // namespace blmd::internal
