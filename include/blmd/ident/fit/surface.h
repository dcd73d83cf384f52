// Cost surfaces (paper §4, Figs. 8-9; docs/surfaces.md): the same cost as the fit
// (FitProblem::Evaluate), over a 1-D or 2-D grid of parameters, the others held at their
// config values. Points are independent: computed in any order, on any number of threads
// or machines (shards), the results are identical.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "blmd/ident/fit/problem.h"

namespace blmd {

struct GridAxis {
  std::string name;
  double low = 0.0, high = 0.0;
  int count = 0;
  bool log_scale = false;
  double Value(int k) const;  // k-th grid value, exact ends
  std::string Spec() const;   // "J=log:1e-4:1e-3:31"
};
// Parses "P=LO:HI:N" or "P=log:LO:HI:N"; throws InputError (flag named in the message).
GridAxis ParseGridAxis(const std::string& text);

struct SurfacePoint {
  std::vector<double> coordinates;  // one per axis
  Evaluation evaluation;
};

struct SurfaceOptions {
  int threads = 0;      // 0: all cores
  int shard_index = 1;  // K of K/N, 1-based
  int shard_count = 1;  // N
  // Points a thread evaluates at once (FitProblem::EvaluateBatch; the blmd model runs 8 in
  // SIMD lanes); 1: one point at a time. The result does not depend on it.
  int batch = 8;
  // Called from worker threads with (points done, points total); may be empty.
  std::function<void(std::size_t, std::size_t)> progress;
};

// Range [first, last) of grid indices (row-major, first axis outermost) of shard K/N.
std::pair<std::size_t, std::size_t> ShardRange(std::size_t total, int index, int count);

// Evaluates the problem at the grid points of the shard. The problem's free parameters
// must be exactly the grid axes, in order.
std::vector<SurfacePoint> ComputeSurface(const FitProblem& problem,
                                         const std::vector<GridAxis>& axes,
                                         const SurfaceOptions& options);

// Grid indices of local minima: strictly lower than every existing neighbour (the 2 in
// 1-D, the 8 in 2-D); non-finite points are never minima.
std::vector<std::size_t> LocalMinima(const std::vector<GridAxis>& axes,
                                     const std::vector<SurfacePoint>& points);

}  // namespace blmd
