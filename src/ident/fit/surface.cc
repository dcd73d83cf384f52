#include "blmd/ident/fit/surface.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "ident/fit/counting_cost.h"
#include "io/flags.h"
#include "parallel.h"

namespace blmd {
double GridAxis::Value(int k) const {
  if (count == 1) return low;
  if (k == 0) return low;
  if (k == count - 1) return high;
  const double f = static_cast<double>(k) / static_cast<double>(count - 1);
  return log_scale ? low * std::pow(high / low, f) : low + f * (high - low);
}

std::string GridAxis::Spec() const {
  return name + "=" + (log_scale ? "log:" : "") + FormatNumber(low) + ":" + FormatNumber(high) +
         ":" + std::to_string(count);
}

GridAxis ParseGridAxis(const std::string& text) {
  const std::string context = "--grid '" + text + "'";
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw InputError(context + ": expected P=LO:HI:N or P=log:LO:HI:N");
  }
  GridAxis axis;
  axis.name = text.substr(0, eq);
  std::string rest = text.substr(eq + 1);
  if (rest.rfind("log:", 0) == 0) {
    axis.log_scale = true;
    rest = rest.substr(4);
  }
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const auto colon = rest.find(':', start);
    parts.push_back(rest.substr(start, colon == std::string::npos ? rest.npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() != 3) throw InputError(context + ": expected P=LO:HI:N or P=log:LO:HI:N");
  axis.low = ParseNumber(parts[0], context + " LO");
  axis.high = ParseNumber(parts[1], context + " HI");
  const double count = ParseNumber(parts[2], context + " N");
  if (count != std::floor(count) || count < 1 || count > 1e6) {
    throw InputError(context + ": N must be a whole number of points >= 1 (got " + parts[2] + ")");
  }
  axis.count = static_cast<int>(count);
  if (!(axis.low < axis.high) && !(axis.count == 1 && axis.low == axis.high)) {
    throw InputError(context + ": the range is inverted or empty (LO must be below HI)");
  }
  if (axis.log_scale && !(axis.low > 0.0)) {
    throw InputError(context + ": a log: axis needs LO > 0");
  }
  return axis;
}

std::pair<std::size_t, std::size_t> ShardRange(std::size_t total, int index, int count) {
  const std::size_t k = static_cast<std::size_t>(index - 1), n = static_cast<std::size_t>(count);
  return {total * k / n, total * (k + 1) / n};
}

std::vector<SurfacePoint> ComputeSurface(const FitProblem& problem,
                                         const std::vector<GridAxis>& axes,
                                         const SurfaceOptions& options) {
  std::size_t total = 1;
  for (const auto& axis : axes) total *= static_cast<std::size_t>(axis.count);
  const std::pair<std::size_t, std::size_t> shard =
      ShardRange(total, options.shard_index, options.shard_count);
  const std::size_t first = shard.first;  // a plain variable: the lambda below captures it
  std::vector<SurfacePoint> points(shard.second - first);
  const int threads = internal::ThreadCount(options.threads);
  // Threads take chunks of options.batch consecutive points (ParallelFor: nothing else
  // shared, each point's result goes to its own slot) and evaluate each chunk at once
  // (FitProblem::EvaluateBatch: the blmd model simulates 8 points in SIMD lanes).
  const std::size_t batch = static_cast<std::size_t>(std::max(1, options.batch));
  std::atomic<std::size_t> done{0};
  const std::size_t chunks = (points.size() + batch - 1) / batch;
  internal::ParallelFor(chunks, threads, [&](std::size_t chunk_index) {
    const std::size_t begin = chunk_index * batch;
    const std::size_t end = std::min(points.size(), begin + batch);
    std::vector<std::vector<double>> chunk;
    for (std::size_t k = begin; k < end; ++k) {
      std::size_t index = first + k;
      std::vector<double> coordinates(axes.size());
      for (std::size_t a = axes.size(); a-- > 0;) {
        const std::size_t n = static_cast<std::size_t>(axes[a].count);
        coordinates[a] = axes[a].Value(static_cast<int>(index % n));
        index /= n;
      }
      points[k].coordinates = coordinates;
      chunk.push_back(std::move(coordinates));
    }
    std::vector<Evaluation> evaluations = problem.EvaluateBatch(chunk);
    for (std::size_t k = begin; k < end; ++k) {
      points[k].evaluation = std::move(evaluations[k - begin]);
      const std::size_t finished = done.fetch_add(1) + 1;
      if (options.progress) options.progress(finished, points.size());
    }
  });
  return points;
}

std::vector<std::size_t> LocalMinima(const std::vector<GridAxis>& axes,
                                     const std::vector<SurfacePoint>& points) {
  std::vector<std::size_t> minima;
  const int n0 = axes[0].count;
  const int n1 = axes.size() > 1 ? axes[1].count : 1;
  auto cost = [&](int i, int j) {
    return points[static_cast<std::size_t>(i) * static_cast<std::size_t>(n1) +
                  static_cast<std::size_t>(j)]
        .evaluation.cost;
  };
  for (int i = 0; i < n0; ++i) {
    for (int j = 0; j < n1; ++j) {
      const double c = cost(i, j);
      if (!std::isfinite(c)) continue;
      bool lowest = true;
      int neighbours = 0;
      for (int di = -1; di <= 1 && lowest; ++di) {
        for (int dj = -1; dj <= 1; ++dj) {
          if (di == 0 && dj == 0) continue;
          const int a = i + di, b = j + dj;
          if (a < 0 || a >= n0 || b < 0 || b >= n1) continue;
          ++neighbours;
          if (!(c < cost(a, b))) {
            lowest = false;
            break;
          }
        }
      }
      if (lowest && neighbours > 0)
        minima.push_back(static_cast<std::size_t>(i) * static_cast<std::size_t>(n1) +
                         static_cast<std::size_t>(j));
    }
  }
  return minima;
}

}  // namespace blmd
