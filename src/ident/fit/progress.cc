#include "blmd/ident/fit/progress.h"

#include <utility>

namespace blmd {

double ProgressSnapshot::StageSecondsLeft() const {
  if (steps > 0) {
    if (steps_done <= 0) return -1.0;
    if (steps_done >= steps) return 0.0;
    return stage_elapsed_s * static_cast<double>(steps - steps_done) /
           static_cast<double>(steps_done);
  }
  if (stage_budget > 0) {
    if (stage_evaluations <= 0) return -1.0;
    if (stage_evaluations >= stage_budget) return 0.0;
    return stage_elapsed_s * static_cast<double>(stage_budget - stage_evaluations) /
           static_cast<double>(stage_evaluations);
  }
  return -1.0;
}

ProgressObserver::ProgressObserver()
    : started_(std::chrono::steady_clock::now()), stage_started_(started_) {}

void ProgressObserver::BeginStage(std::string name, int steps) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stage_ = std::move(name);
    stage_started_ = std::chrono::steady_clock::now();
    stage_first_evaluation_ = evaluations_.load();
    stage_budget_ = 0;
    steps_ = steps;
    ++stage_number_;
    steps_done_.store(0);
    best_cost_.store(std::numeric_limits<double>::infinity());
  }
  OnStage(Snapshot());
}

void ProgressObserver::ExpectEvaluations(long count) {
  std::lock_guard<std::mutex> lock(mutex_);
  stage_budget_ = evaluations_.load() - stage_first_evaluation_ + count;
}

void ProgressObserver::StepDone() { steps_done_.fetch_add(1); }

ProgressSnapshot ProgressObserver::Snapshot() const {
  const auto now = std::chrono::steady_clock::now();
  ProgressSnapshot s;
  std::lock_guard<std::mutex> lock(mutex_);
  s.stage = stage_;
  s.evaluations = evaluations_.load();
  s.stage_evaluations = s.evaluations - stage_first_evaluation_;
  s.stage_budget = stage_budget_;
  s.steps = steps_;
  s.steps_done = steps_done_.load();
  s.best_cost = best_cost_.load();
  s.elapsed_s = std::chrono::duration<double>(now - started_).count();
  s.stage_elapsed_s = std::chrono::duration<double>(now - stage_started_).count();
  s.stage_number = stage_number_;
  return s;
}

}  // namespace blmd
