// Helpers shared by the tests: paths, running the real commands, temporary folders.
#pragma once

#include <string>

#include "blmd/io/config.h"
#include "blmd/sim/trace.h"

namespace blmd::testing {

std::string SourcePath(const std::string& relative);  // repository root + relative
std::string BinPath(const std::string& command);      // build/bin/<command>

struct CommandResult {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};
// Runs `command_line` through /bin/sh, capturing stdout and stderr.
CommandResult Run(const std::string& command_line);

// A fresh empty folder under the build tree's temp area, removed at destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const { return path_ + "/" + name; }
  // Writes `content` to File(name) and returns its path.
  std::string Write(const std::string& name, const std::string& content) const;

 private:
  std::string path_;
};

bool FileExists(const std::string& path);
// The file's bytes ("" when it cannot be read).
std::string Slurp(const std::string& path);

// Worst |fast - reference| / max |reference| over the columns (the column in *where); the two
// traces must have the same columns and rows (checked with EXPECTs).
double WorstRelativeDeviation(const Trace& fast, const Trace& reference, std::string* where);

// `config`'s experiment simulated with `effect` at `values` added (checked with an EXPECT): a
// record of an effect the config does not declare.
Trace SimulateWithEffect(Config config, const std::string& effect, const ParameterSet& values);

// A config's experiment.input that is a sine of `amplitude` at `hz` from t = 0 (a chirp whose
// two frequencies are the same), for a frequency response read at one frequency.
std::string SineInput(double amplitude, double hz);

}  // namespace blmd::testing
