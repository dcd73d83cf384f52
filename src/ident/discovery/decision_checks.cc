// The decisions discovery checks on the stability check's perturbed copies
// (src/ident/discovery/screening.h, docs/discovery.md §3d): a score that crosses the
// evidence threshold, the cross-validated choice between two candidates, and a statistic's
// side of its threshold on the copies' scatter.
#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "ident/discovery/screening.h"

namespace blmd {

namespace internal {

bool ScoreMoveReverses(double on_data, double on_copy, double margin, double tolerance) {
  const bool passes_on_data = on_data < -margin;
  const bool passes_on_copy = on_copy < -margin;
  return passes_on_data != passes_on_copy && !(std::abs(on_copy - on_data) <= tolerance);
}

bool GivesWay(double first_nrmse, double other_nrmse, bool simpler, double margin) {
  return simpler ? !(first_nrmse < (1.0 - margin) * other_nrmse)
                 : other_nrmse < (1.0 - margin) * first_nrmse;
}

std::optional<std::size_t> FirstCopyReversingChoice(const CandidateOutcome& first,
                                                    const CandidateOutcome& other, bool simpler,
                                                    double margin) {
  if (!first.cross_validated || !other.cross_validated) return std::nullopt;
  const bool on_data = GivesWay(first.cv_after, other.cv_after, simpler, margin);
  const std::size_t copies = std::min(first.cv_perturbed.size(), other.cv_perturbed.size());
  for (std::size_t c = 0; c < copies; ++c) {
    const double f = first.cv_perturbed[c], g = other.cv_perturbed[c];
    if (std::isfinite(f) && std::isfinite(g) && GivesWay(f, g, simpler, margin) != on_data)
      return c;
  }
  return std::nullopt;
}

SideCheck CheckSide(const std::vector<double>& samples, double threshold) {
  SideCheck check;
  if (samples.empty() || !std::isfinite(samples.front())) return check;
  const bool below = samples.front() < threshold;
  std::vector<double> finite;
  for (double s : samples) {
    if (!std::isfinite(s)) continue;
    finite.push_back(s);
    if ((s < threshold) != below) check.holds = false;
  }
  const double n = static_cast<double>(finite.size());
  double mean = 0.0;
  for (double s : finite) mean += s / n;
  check.low = check.high = samples.front();
  if (finite.size() < 2) return check;
  double squares = 0.0;
  for (double s : finite) squares += (s - mean) * (s - mean);
  const double sd = std::sqrt(squares / (n - 1.0));
  const double t =
      boost::math::quantile(boost::math::complement(boost::math::students_t(n - 1.0), 0.025));
  const double half = t * sd * std::sqrt(1.0 + 1.0 / n);
  check.low = mean - half;
  check.high = mean + half;
  if (check.low < threshold && threshold < check.high) check.holds = false;
  return check;
}

SideCheck CheckRatio(const std::vector<double>& ratios, double threshold) {
  std::vector<double> logs;
  for (double r : ratios)
    logs.push_back(r > 0.0 ? std::log(r) : std::numeric_limits<double>::quiet_NaN());
  SideCheck check = CheckSide(logs, std::log(threshold));
  check.low = std::exp(check.low);
  check.high = std::exp(check.high);
  return check;
}

std::vector<double> ChoiceRatios(const CandidateOutcome& first, const CandidateOutcome& other,
                                 bool simpler) {
  auto ratio = [&](double f, double g) { return simpler ? f / g : g / f; };
  std::vector<double> ratios = {ratio(first.cv_after, other.cv_after)};
  const std::size_t copies = std::min(first.cv_perturbed.size(), other.cv_perturbed.size());
  for (std::size_t c = 0; c < copies; ++c)
    ratios.push_back(ratio(first.cv_perturbed[c], other.cv_perturbed[c]));
  return ratios;
}

}  // namespace internal

}  // namespace blmd
