// Where a shaft rests (private to ident): the runs of samples over which a speed stays within
// a limit for long enough to be a shaft held still (by friction or a loop), not a speed
// passing through zero. Used by the equation error's static friction at rest
// (docs/identification.md §8b) and by discovery's plausibility of spring and gravity
// (docs/discovery.md §2).
#pragma once

#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

namespace blmd::internal {

// The runs [begin, end) of at least 20 samples and 0.1 s over which |w| <= limit (a finite
// w), in order. `t` and `w` have the same length.
inline std::vector<std::pair<std::size_t, std::size_t>> RestRuns(const std::vector<double>& t,
                                                                 const std::vector<double>& w,
                                                                 double limit) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  std::size_t begin = 0;
  for (std::size_t k = 0; k <= w.size(); ++k) {
    if (k < w.size() && std::isfinite(w[k]) && std::abs(w[k]) <= limit) continue;
    if (k - begin >= 20 && t[k - 1] - t[begin] >= 0.1) runs.emplace_back(begin, k);
    begin = k + 1;
  }
  return runs;
}

}  // namespace blmd::internal
