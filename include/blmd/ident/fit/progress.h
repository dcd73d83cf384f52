// Progress of a long identification (docs/cli.md §2.3, --progress): what it is doing (the
// stage), how many cost evaluations it made, the lowest cost so far, and, where a total is
// known, how far along it is. The optimisers and discovery feed a ProgressObserver they are
// given (OptimizerOptions::progress, null: no progress, nothing counted); a renderer reads it
// (report/progress.h draws it as one line on stderr).
//
// Stages follow one another: the orchestrator (blmd::Identify, Discover, LeaveOneTraceOut)
// begins a stage, the work inside it counts evaluations and steps, from any number of
// threads. Evaluated() is lock-free (two atomics); the stage's text is behind a mutex.
#pragma once

#include <atomic>
#include <chrono>
#include <limits>
#include <mutex>
#include <string>

namespace blmd {

// What a ProgressObserver holds at one instant.
struct ProgressSnapshot {
  std::string stage;              // e.g. "first fit (ceres)", "discovery round 1: screening"
  long evaluations = 0;           // cost evaluations since the observer was made
  long stage_evaluations = 0;     // of which in the current stage
  long stage_budget = 0;          // evaluations the stage expects in all (0: unknown)
  int steps_done = 0, steps = 0;  // items of the stage (refits, candidates) done of `steps`
  double best_cost = std::numeric_limits<double>::infinity();  // lowest finite cost of the stage
  double elapsed_s = 0.0;                                      // since the observer was made
  double stage_elapsed_s = 0.0;                                // since the stage began
  int stage_number = 0;  // stages begun so far (1 for the first)

  // Seconds left in the stage, from its rate so far: by steps when it has steps (and one is
  // done), else by evaluations when it has a budget (and one is made); negative: unknown.
  double StageSecondsLeft() const;
};

class ProgressObserver {
 public:
  ProgressObserver();
  virtual ~ProgressObserver() = default;
  ProgressObserver(const ProgressObserver&) = delete;
  ProgressObserver& operator=(const ProgressObserver&) = delete;

  // A new stage of `steps` items (0: the stage has no items): resets the stage's counts,
  // budget and best cost, then calls OnStage.
  void BeginStage(std::string name, int steps = 0);
  // The stage expects `count` more evaluations from now (its budget: FSD's schedule).
  void ExpectEvaluations(long count);
  // One item of the stage finished (thread-safe).
  void StepDone();
  // One cost evaluation made; a non-finite cost (a failed simulation) counts but is never
  // the best. Thread-safe and lock-free.
  void Evaluated(double cost) {
    evaluations_.fetch_add(1, std::memory_order_relaxed);
    double best = best_cost_.load(std::memory_order_relaxed);
    while (cost < best &&
           !best_cost_.compare_exchange_weak(best, cost, std::memory_order_relaxed)) {
    }
  }

  ProgressSnapshot Snapshot() const;

 protected:
  // Called after every BeginStage, on the thread that began it, outside the observer's lock.
  virtual void OnStage(const ProgressSnapshot& /*snapshot*/) {}

 private:
  const std::chrono::steady_clock::time_point started_;
  std::atomic<long> evaluations_{0};
  std::atomic<double> best_cost_{std::numeric_limits<double>::infinity()};
  std::atomic<int> steps_done_{0};
  mutable std::mutex mutex_;  // the fields below
  std::string stage_;
  std::chrono::steady_clock::time_point stage_started_;
  long stage_first_evaluation_ = 0;
  long stage_budget_ = 0;
  int steps_ = 0;
  int stage_number_ = 0;
};

}  // namespace blmd
