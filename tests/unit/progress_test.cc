// The progress of an identification (ident/fit/progress.h, report/progress.h): the observer's
// counts from many threads, its stages, the time left, the line drawn, the printer's bytes,
// and Identify feeding it (every evaluation of the fit counted, its stages in order).
#include "blmd/ident/fit/progress.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "app/request.h"
#include "blmd/app/identify.h"
#include "blmd/io/config.h"
#include "blmd/report/progress.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::SourcePath;

TEST(ProgressObserver, CountsFromSeveralThreadsAddUpAndTheBestIsTheMinimum) {
  ProgressObserver progress;
  progress.BeginStage("stage", 8);
  constexpr int kThreads = 8;
  constexpr int kPerThread = 20000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&progress, t] {
      for (int k = 0; k < kPerThread; ++k) {
        // Costs 1 + (k * 8 + t) / 1e6 ... and, from thread 5 once, the minimum 0.25; failed
        // evaluations (infinite, NaN) count but are never the best.
        const double cost = 1.0 + static_cast<double>(k * kThreads + t) * 1e-6;
        progress.Evaluated(t == 5 && k == 12345 ? 0.25 : cost);
        if (k % 1000 == 0) progress.Evaluated(std::numeric_limits<double>::infinity());
        if (k % 1000 == 1) progress.Evaluated(std::nan(""));
      }
      progress.StepDone();
    });
  }
  for (auto& thread : threads) thread.join();
  const ProgressSnapshot s = progress.Snapshot();
  const long expected = static_cast<long>(kThreads) * (kPerThread + 2 * kPerThread / 1000);
  EXPECT_EQ(s.evaluations, expected);
  EXPECT_EQ(s.stage_evaluations, expected);
  EXPECT_EQ(s.best_cost, 0.25);
  EXPECT_EQ(s.steps_done, 8);
  EXPECT_EQ(s.steps, 8);
  EXPECT_EQ(s.stage, "stage");
  EXPECT_EQ(s.stage_number, 1);

  // A new stage: its own counts and best, the run's total kept.
  progress.BeginStage("next");
  progress.Evaluated(3.0);
  progress.Evaluated(2.0);
  progress.Evaluated(4.0);
  const ProgressSnapshot n = progress.Snapshot();
  EXPECT_EQ(n.stage, "next");
  EXPECT_EQ(n.stage_number, 2);
  EXPECT_EQ(n.evaluations, expected + 3);
  EXPECT_EQ(n.stage_evaluations, 3);
  EXPECT_EQ(n.best_cost, 2.0);
  EXPECT_EQ(n.steps, 0);
  EXPECT_EQ(n.steps_done, 0);
  EXPECT_EQ(n.stage_budget, 0);
  EXPECT_LE(n.stage_elapsed_s, n.elapsed_s);
}

TEST(ProgressObserver, ABudgetCountsFromWhenItIsSet) {
  ProgressObserver progress;
  progress.BeginStage("fsd");
  for (int k = 0; k < 10; ++k) progress.Evaluated(1.0);
  progress.ExpectEvaluations(90);
  EXPECT_EQ(progress.Snapshot().stage_budget, 100);
  for (int k = 0; k < 30; ++k) progress.Evaluated(1.0);
  progress.ExpectEvaluations(5);  // a later phase resets what is left
  EXPECT_EQ(progress.Snapshot().stage_budget, 45);
  EXPECT_EQ(progress.Snapshot().stage_evaluations, 40);
}

TEST(ProgressObserver, TimeLeftFromStepsElseFromTheBudget) {
  ProgressSnapshot s;
  s.stage_elapsed_s = 2.0;
  EXPECT_EQ(s.StageSecondsLeft(), -1.0);  // nothing known
  s.stage_evaluations = 50;
  EXPECT_EQ(s.StageSecondsLeft(), -1.0);  // evaluations without a budget: unknown
  s.stage_budget = 200;
  EXPECT_DOUBLE_EQ(s.StageSecondsLeft(), 6.0);  // 50 in 2 s, 150 to go
  s.stage_evaluations = 250;
  EXPECT_EQ(s.StageSecondsLeft(), 0.0);   // over budget
  s.steps = 8;                            // steps win over the budget
  EXPECT_EQ(s.StageSecondsLeft(), -1.0);  // none done yet
  s.steps_done = 2;
  EXPECT_DOUBLE_EQ(s.StageSecondsLeft(), 6.0);  // 2 in 2 s, 6 to go
  s.steps_done = 8;
  EXPECT_EQ(s.StageSecondsLeft(), 0.0);
}

TEST(ProgressLine, ReadsAsDocumented) {
  EXPECT_EQ(ProgressDuration(0.0), "0.0 s");
  EXPECT_EQ(ProgressDuration(3.14), "3.1 s");
  EXPECT_EQ(ProgressDuration(59.9), "59.9 s");
  EXPECT_EQ(ProgressDuration(59.97), "1:00 min");
  EXPECT_EQ(ProgressDuration(245.0), "4:05 min");
  EXPECT_EQ(ProgressDuration(3723.0), "1:02:03 h");
  EXPECT_EQ(ProgressDuration(-1.0), "?");

  ProgressSnapshot s;
  s.stage = "first fit (fsd)";
  s.elapsed_s = 3.1;
  EXPECT_EQ(ProgressLine(s), "first fit (fsd): 3.1 s");
  s.stage_budget = 3400;
  EXPECT_EQ(ProgressLine(s), "first fit (fsd): 0/3400 evaluations, 3.1 s");
  s.stage_evaluations = 1234;
  s.stage_elapsed_s = 2.0;
  s.best_cost = 2.4561e-4;
  EXPECT_EQ(ProgressLine(s),
            "first fit (fsd): 1234/3400 evaluations, best cost 0.0002456, 3.1 s, 3.5 s left");
  ProgressSnapshot d;
  d.stage = "discovery round 1: screening";
  d.steps = 8;
  d.steps_done = 2;
  d.stage_evaluations = 1;
  d.stage_elapsed_s = 10.0;
  d.elapsed_s = 12.0;
  d.best_cost = 1.5;
  EXPECT_EQ(ProgressLine(d),
            "discovery round 1: screening 2/8: 1 evaluation, best cost 1.5, 12.0 s, 30.0 s left");
  d.evaluations = 4321;
  d.elapsed_s = 75.0;
  EXPECT_EQ(ProgressFinalLine(d), "done: 4321 evaluations, 1:15 min");
}

// The printer's bytes in a file (no periodic redraw in this test: a one-hour interval).
std::string PrinterOutput(bool finish) {
  std::FILE* file = std::tmpfile();
  EXPECT_NE(file, nullptr);
  {
    ProgressPrinter printer(file, "tool: ", 0, std::chrono::hours(1));
    printer.BeginStage("a stage with a long name");
    printer.Evaluated(2.0);
    printer.BeginStage("b", 3);
    printer.Evaluated(1.0);
    printer.Evaluated(0.5);
    if (finish) {
      printer.Finish();
      printer.Finish();  // once
    }
  }
  std::rewind(file);
  std::string text;
  for (int c = std::fgetc(file); c != EOF; c = std::fgetc(file)) text += static_cast<char>(c);
  std::fclose(file);
  return text;
}

TEST(ProgressPrinter, RedrawsInPlaceAndEndsWithOneNewline) {
  const std::string text = PrinterOutput(true);
  // Every stage drawn when it begins, over the line before (\r, spaces over the rest of a
  // longer one), then the final line and one newline.
  const std::string first = "\rtool: a stage with a long name: ";
  ASSERT_EQ(text.rfind(first, 0), 0u) << text;
  const std::size_t second = text.find("\rtool: b 0/3: ");
  ASSERT_NE(second, std::string::npos) << text;
  const std::size_t last = text.find("\rtool: done: 3 evaluations, ");
  ASSERT_NE(last, std::string::npos) << text;
  EXPECT_LT(second, last);
  // The first line's length, so the second is padded to it.
  const std::size_t first_length = second - 1;  // without its \r
  EXPECT_EQ(text.find('\r', 1), second);
  const std::string second_line = text.substr(second + 1, last - second - 1);
  EXPECT_EQ(second_line.size(), first_length) << second_line;
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\r'), 3);
}

TEST(ProgressPrinter, WithoutFinishTheLineAsItStoodIsEnded) {
  const std::string text = PrinterOutput(false);
  EXPECT_EQ(text.find("done:"), std::string::npos) << text;
  const std::size_t last = text.rfind("\rtool: b 0/3: 2 evaluations, best cost 0.5, ");
  ASSERT_NE(last, std::string::npos) << text;
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1);
}

TEST(ProgressPrinter, CutsLinesToTheTerminalWidth) {
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  {
    ProgressPrinter printer(file, "tool: ", 20, std::chrono::hours(1));
    printer.BeginStage("a stage far longer than twenty columns");
  }
  std::rewind(file);
  char buffer[128] = {};
  const std::size_t n = std::fread(buffer, 1, sizeof buffer - 1, file);
  std::fclose(file);
  // 19 columns: drawn when the stage began, then again, ended, when the printer went.
  EXPECT_EQ(std::string(buffer, n), "\rtool: a stage far l\rtool: a stage far l\n");
}

// Records every stage as it begins.
class StageRecorder : public ProgressObserver {
 public:
  std::vector<std::string> stages;

 protected:
  void OnStage(const ProgressSnapshot& snapshot) override {
    std::lock_guard<std::mutex> lock(mutex_);
    stages.push_back(snapshot.stage);
  }

 private:
  std::mutex mutex_;
};

IdentRequest GaneshRequest(int traces) {
  IdentSettings settings;
  for (int k = 0; k < traces; ++k)
    settings.traces.push_back({SourcePath("testdata/ganesh-noload-step.csv"), std::nullopt});
  const std::string config = SourcePath("configs/ganesh-noload.json");
  return MakeIdentRequest(LoadConfig(config), config, settings);
}

TEST(ProgressOfIdentify, CountsEveryEvaluationOfTheFitAndNamesItsStages) {
  StageRecorder progress;
  IdentRequest request = GaneshRequest(1);
  request.options.progress = &progress;
  const IdentOutcome outcome = Identify(std::move(request));
  ASSERT_TRUE(outcome.converged());
  EXPECT_EQ(progress.stages,
            (std::vector<std::string>{"first fit (ceres)", "noise-weighted refit (ceres)", "report",
                                      "adequacy check"}));
  // The fits (the first and the noise-weighted refits): the observer saw exactly the
  // evaluations they counted.
  const ProgressSnapshot s = progress.Snapshot();
  EXPECT_GT(outcome.first_fit.summary.evaluations, 0);
  EXPECT_GE(outcome.noise.fits, 2);
  EXPECT_EQ(s.evaluations, outcome.noise.evaluations);
  EXPECT_EQ(s.stage_evaluations, 0);  // the adequacy check evaluates nothing it counts
}

TEST(ProgressOfIdentify, ThreeTracesAddTheLeaveOneTraceOutRefitsAsSteps) {
  StageRecorder progress;
  IdentRequest request = GaneshRequest(3);
  request.options.progress = &progress;
  const IdentOutcome outcome = Identify(std::move(request));
  ASSERT_TRUE(outcome.converged());
  EXPECT_EQ(progress.stages,
            (std::vector<std::string>{"first fit (ceres)", "noise-weighted refit (ceres)",
                                      "leave-one-trace-out refits", "report", "adequacy check"}));
  const ProgressSnapshot s = progress.Snapshot();
  EXPECT_EQ(s.stage_number, 5);
  EXPECT_GT(s.evaluations, outcome.noise.evaluations);  // + the three refits
}

TEST(ProgressOfIdentify, NoObserverNoChange) {
  // The same fit with and without an observer: the same values, bit for bit.
  StageRecorder progress;
  IdentRequest with = GaneshRequest(1);
  with.options.progress = &progress;
  const IdentOutcome a = Identify(std::move(with));
  const IdentOutcome b = Identify(GaneshRequest(1));
  EXPECT_EQ(a.first_fit.values, b.first_fit.values);
  EXPECT_EQ(a.first_fit.summary.evaluations, b.first_fit.summary.evaluations);
}

}  // namespace
}  // namespace blmd
