#include "blmd/report/progress.h"

#include <cmath>
#include <utility>

#include "blmd/io/csv.h"

namespace blmd {

std::string ProgressDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return "?";
  char buffer[48];
  if (seconds < 59.95) {
    std::snprintf(buffer, sizeof buffer, "%.1f s", seconds);
  } else {
    const long s = std::lround(seconds);
    if (s < 3600) {
      std::snprintf(buffer, sizeof buffer, "%ld:%02ld min", s / 60, s % 60);
    } else {
      std::snprintf(buffer, sizeof buffer, "%ld:%02ld:%02ld h", s / 3600, s / 60 % 60, s % 60);
    }
  }
  return buffer;
}

std::string ProgressLine(const ProgressSnapshot& s) {
  std::string line = s.stage;
  if (s.steps > 0) line += " " + std::to_string(s.steps_done) + "/" + std::to_string(s.steps);
  line += ": ";
  if (s.stage_evaluations > 0 || s.stage_budget > 0) {
    line += std::to_string(s.stage_evaluations);
    if (s.stage_budget > 0) line += "/" + std::to_string(s.stage_budget);
    line += s.stage_evaluations == 1 && s.stage_budget <= 0 ? " evaluation, " : " evaluations, ";
  }
  if (std::isfinite(s.best_cost)) line += "best cost " + FormatSignificant(s.best_cost, 4) + ", ";
  line += ProgressDuration(s.elapsed_s);
  const double left = s.StageSecondsLeft();
  if (left >= 0.0) line += ", " + ProgressDuration(left) + " left";
  return line;
}

std::string ProgressFinalLine(const ProgressSnapshot& s) {
  return "done: " + std::to_string(s.evaluations) +
         (s.evaluations == 1 ? " evaluation, " : " evaluations, ") + ProgressDuration(s.elapsed_s);
}

ProgressPrinter::ProgressPrinter(std::FILE* out, std::string prefix, int width,
                                 std::chrono::milliseconds interval)
    : out_(out), prefix_(std::move(prefix)), width_(width), interval_(interval) {
  redraws_ = std::thread([this] {
    std::unique_lock<std::mutex> lock(stop_mutex_);
    while (!wake_.wait_for(lock, interval_, [this] { return stop_; })) {
      lock.unlock();
      Redraw();
      lock.lock();
    }
  });
}

ProgressPrinter::~ProgressPrinter() {
  StopRedraws();
  // Not finished (an error on the way): the line as it stood, ended, so that the error
  // message starts a line of its own.
  const ProgressSnapshot snapshot = Snapshot();
  if (snapshot.stage_number > 0) Draw(ProgressLine(snapshot), true);
}

void ProgressPrinter::StopRedraws() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (redraws_.joinable()) redraws_.join();
}

void ProgressPrinter::Finish() {
  StopRedraws();
  Draw(ProgressFinalLine(Snapshot()), true);
}

void ProgressPrinter::OnStage(const ProgressSnapshot& snapshot) {
  Draw(ProgressLine(snapshot), false);
}

void ProgressPrinter::Redraw() {
  const ProgressSnapshot snapshot = Snapshot();
  if (snapshot.stage_number == 0) return;  // nothing begun yet
  Draw(ProgressLine(snapshot), false);
}

void ProgressPrinter::Draw(const std::string& text, bool last) {
  std::lock_guard<std::mutex> lock(draw_mutex_);
  if (finished_) return;
  std::string line = prefix_ + text;
  if (width_ > 1 && line.size() > static_cast<std::size_t>(width_ - 1))
    line.resize(static_cast<std::size_t>(width_ - 1));
  // Spaces over what is left of a longer line before (no terminal escapes: the same bytes
  // read well in a file).
  const std::size_t length = line.size();
  if (length < drawn_) line.append(drawn_ - length, ' ');
  std::fputs(("\r" + line + (last ? "\n" : "")).c_str(), out_);
  std::fflush(out_);
  drawn_ = length;
  finished_ = last;
}

}  // namespace blmd
