// The progress of an identification as one line on a terminal (docs/cli.md §2.3,
// blmd-ident --progress): a ProgressObserver (ident/fit/progress.h) that redraws its state,
//   blmd-ident: first fit (fsd): 862/1916 evaluations, best cost 0.001171, 23.6 s, 28.9 s left
// in place (carriage return, no newline) at most every `interval` and at every new stage,
// and ends with a final line and a newline.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>

#include "blmd/ident/fit/progress.h"

namespace blmd {

// A duration for people: "3.1 s" below a minute, "4:05 min" below an hour, "1:02:03 h".
std::string ProgressDuration(double seconds);

// One line of progress, without the command's name:
//   "<stage>[ <done>/<steps>]: <n>[/<budget>] evaluations, best cost <c>, <elapsed>[, <left> left]"
// the evaluations and the best cost are the stage's (left out while there are none), the
// elapsed time the whole run's, the time left the stage's (when it is known, progress.h).
std::string ProgressLine(const ProgressSnapshot& snapshot);
// The last line: "done: <n> evaluations, <elapsed>".
std::string ProgressFinalLine(const ProgressSnapshot& snapshot);

class ProgressPrinter : public ProgressObserver {
 public:
  // Draws on `out` (not owned; stderr for the commands), each line prefixed with `prefix`
  // ("blmd-ident: ") and cut to `width` - 1 characters when `width` > 0 (a terminal's
  // columns: a wrapped line could not be redrawn in place). Starts a thread that redraws
  // every `interval`.
  ProgressPrinter(std::FILE* out, std::string prefix, int width,
                  std::chrono::milliseconds interval = std::chrono::milliseconds(200));
  // Without Finish(): ends the line as it stands with a newline (an error on the way).
  ~ProgressPrinter() override;
  ProgressPrinter(const ProgressPrinter&) = delete;
  ProgressPrinter& operator=(const ProgressPrinter&) = delete;

  // Stops the redraws and draws the final line (ProgressFinalLine) with a newline; once.
  void Finish();

 protected:
  void OnStage(const ProgressSnapshot& snapshot) override;

 private:
  void StopRedraws();
  void Draw(const std::string& line, bool last);
  void Redraw();

  std::FILE* const out_;
  const std::string prefix_;
  const int width_;
  const std::chrono::milliseconds interval_;
  std::mutex draw_mutex_;  // out_, drawn_, finished_
  std::size_t drawn_ = 0;  // length of the line on screen
  bool finished_ = false;
  std::mutex stop_mutex_;  // stop_
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread redraws_;  // last: started once everything else is set
};

}  // namespace blmd
