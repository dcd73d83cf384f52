#include "blmd/ident/fit/cutoff_choice.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "blmd/format.h"

namespace blmd {

bool EstimatesAgree(const std::vector<ParameterEstimate>& a,
                    const std::vector<ParameterEstimate>& b) {
  if (a.size() != b.size() || a.empty()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const auto determined = [](const ParameterEstimate& e) {
      return !e.has_white_interval ||
             0.5 * (e.ci95_white_high - e.ci95_white_low) <= 0.5 * std::abs(e.value);
    };
    if (!determined(a[k]) || !determined(b[k])) continue;
    if (!(std::abs(a[k].value - b[k].value) <= kCutoffRelativeTolerance * std::abs(a[k].value)))
      return false;
  }
  return true;
}

std::vector<double> CutoffLadder(double sample_hz, double user_hz, int count) {
  std::vector<double> ladder;
  // Rounded to six significant digits: a sample rate read from time stamps is 1000 Hz to
  // its last bit or two, and a cut-off is written and read back as a number a user types.
  const auto rounded = [](double hz) { return std::stod(FormatSignificant(hz, 6)); };
  for (int k = 0; k < count; ++k) ladder.push_back(rounded(0.1 * sample_hz / std::ldexp(1.0, k)));
  if (user_hz > 0.0) {
    // The user's cut-off replaces the nearest level (on a log scale) so that it is judged
    // against its neighbours.
    std::size_t nearest = 0;
    for (std::size_t k = 1; k < ladder.size(); ++k) {
      if (std::abs(std::log(ladder[k] / user_hz)) < std::abs(std::log(ladder[nearest] / user_hz)))
        nearest = k;
    }
    ladder[nearest] = user_hz;
    std::sort(ladder.begin(), ladder.end(), std::greater<>());
  }
  return ladder;
}

void DecideCutoff(CutoffChoice* choice) {
  std::vector<CutoffLevel>& levels = choice->levels;
  for (std::size_t k = 0; k + 1 < levels.size(); ++k) {
    levels[k].agrees_below = levels[k].ok && levels[k + 1].ok &&
                             EstimatesAgree(levels[k].estimates, levels[k + 1].estimates);
  }
  // The longest run of agreeing neighbours (ties: the highest cut-offs).
  std::size_t best_begin = 0, best_length = 0;
  for (std::size_t k = 0; k < levels.size();) {
    if (!levels[k].agrees_below) {
      ++k;
      continue;
    }
    std::size_t end = k;
    while (end < levels.size() && levels[end].agrees_below) ++end;
    const std::size_t length = end - k + 1;  // levels k .. end
    if (length > best_length) {
      best_begin = k;
      best_length = length;
    }
    k = end + 1;
  }
  choice->plateau = best_length >= 2;
  auto hz = [](double v) { return FormatSignificant(v, 3) + " Hz"; };
  if (choice->plateau) {
    const std::size_t last = best_begin + best_length - 1;
    choice->stable_high_hz = levels[best_begin].hz;
    choice->stable_low_hz = levels[last].hz;
  }
  const std::string plateau_text =
      choice->plateau
          ? "J and the other determined estimates move by less than 2 % per octave from " +
                hz(choice->stable_low_hz) + " to " + hz(choice->stable_high_hz)
          : "no two neighbouring cut-offs of " + hz(levels.back().hz) + " to " +
                hz(levels.front().hz) + " give estimates that agree";
  if (!choice->user_set) {
    choice->chosen_hz = choice->plateau ? choice->stable_high_hz : 0.1 * choice->sample_hz;
    choice->sensitive = !choice->plateau;
    choice->reason =
        choice->plateau
            ? "chosen from the data: the highest cut-off of the plateau (" + plateau_text + ")"
            : "sample rate / 10 (" + plateau_text + ")";
    return;
  }
  // A user's cut-off: on the plateau, or agreeing with a neighbour.
  std::size_t at = 0;
  for (std::size_t k = 0; k < levels.size(); ++k) {
    if (levels[k].hz == choice->chosen_hz) at = k;
  }
  const bool with_below = levels[at].agrees_below;
  const bool with_above = at > 0 && levels[at - 1].agrees_below;
  const bool on_plateau = choice->plateau && choice->chosen_hz <= choice->stable_high_hz &&
                          choice->chosen_hz >= choice->stable_low_hz;
  choice->sensitive = !on_plateau && !(with_below || with_above);
  choice->reason = "as set (" + plateau_text + ")";
}

}  // namespace blmd
