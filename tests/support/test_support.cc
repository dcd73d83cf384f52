#include "support/test_support.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "blmd/run.h"

namespace blmd::testing {

std::string SourcePath(const std::string& relative) {
  return std::string(BLMD_SOURCE_DIR) + "/" + relative;
}

std::string BinPath(const std::string& command) {
  return std::string(BLMD_BIN_DIR) + "/" + command;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

namespace {

// With BLMD_REPORT_SINK set (tests/CMakeLists.txt, schema_suite_reports), every JSON report a
// command run by the tests writes is copied there, to be validated against the JSON Schemas
// after the suite: blmd-ident's --report file and --json output (report-*.json), and
// blmd-surface's --json output (surface-*.json). Only runs that may have written one (exit
// 0, 1 or 3) count, and a --report file only when the run created or changed it and it is a
// regular file (not a device or FIFO, not a file a failed write left as it was).
class ReportSink {
 public:
  explicit ReportSink(const std::string& command_line) {
    const char* sink = std::getenv("BLMD_REPORT_SINK");
    if (!sink || !*sink) return;
    sink_ = sink;
    std::istringstream words(command_line);
    for (std::string word; words >> word;) {
      if (word.size() >= 2 && word.front() == '\'' && word.back() == '\'')
        word = word.substr(1, word.size() - 2);
      argv_.push_back(word);
    }
    ident_ = Runs("blmd-ident");
    surface_ = Runs("blmd-surface");
    for (std::size_t k = 1; ident_ && k < argv_.size(); ++k) {
      std::string path;
      if (argv_[k] == "--report" && k + 1 < argv_.size()) path = argv_[k + 1];
      if (argv_[k].rfind("--report=", 0) == 0) path = argv_[k].substr(9);
      if (!path.empty()) reports_.push_back({path, Stamp(path)});
    }
  }
  void After(const CommandResult& result) const {
    if (sink_.empty() || (!ident_ && !surface_)) return;
    if (result.exit_code != 0 && result.exit_code != 1 && result.exit_code != 3) return;
    for (const auto& [path, before] : reports_) {
      struct stat info {};
      if (stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) && Stamp(path) != before) {
        Keep("report", Slurp(path));
      }
    }
    const bool json = std::find(argv_.begin(), argv_.end(), "--json") != argv_.end();
    if (json && !result.out.empty()) Keep(ident_ ? "report" : "surface", result.out);
  }

 private:
  bool Runs(const std::string& command) const {  // a word naming the command (VAR=... first ok)
    return std::any_of(argv_.begin(), argv_.end(), [&](const std::string& word) {
      return word == command ||
             (word.size() > command.size() && word.compare(word.size() - command.size() - 1,
                                                           std::string::npos, "/" + command) == 0);
    });
  }
  static std::string Stamp(const std::string& path) {  // "" when absent
    struct stat info {};
    if (stat(path.c_str(), &info) != 0) return "";
    return std::to_string(info.st_mtim.tv_sec) + "." + std::to_string(info.st_mtim.tv_nsec) + ":" +
           std::to_string(info.st_size) + ":" + std::to_string(info.st_ino);
  }
  void Keep(const std::string& kind, const std::string& text) const {
    std::error_code ignored;
    std::filesystem::create_directories(sink_, ignored);
    std::string pattern = sink_ + "/" + kind + "-XXXXXX.json";
    const int fd = mkstemps(pattern.data(), 5);
    if (fd < 0) return;
    close(fd);
    std::ofstream(pattern, std::ios::binary) << text;
  }

  std::string sink_;
  std::vector<std::string> argv_;
  bool ident_ = false, surface_ = false;
  std::vector<std::pair<std::string, std::string>> reports_;  // path, stamp before the run
};

}  // namespace

CommandResult Run(const std::string& command_line) {
  const ReportSink sink(command_line);
  TempDir capture;
  const std::string out = capture.File("stdout"), err = capture.File("stderr");
  const std::string full = "(" + command_line + ") >" + out + " 2>" + err + " </dev/null";
  const int status = std::system(full.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = Slurp(out);
  result.err = Slurp(err);
  sink.After(result);
  return result;
}

TempDir::TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "blmd-test-XXXXXX").string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::string TempDir::Write(const std::string& name, const std::string& content) const {
  const std::string path = File(name);
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

bool FileExists(const std::string& path) {
  struct stat info {};
  return stat(path.c_str(), &info) == 0;
}

double WorstRelativeDeviation(const Trace& fast, const Trace& reference, std::string* where) {
  EXPECT_EQ(fast.names(), reference.names());
  EXPECT_EQ(fast.rows(), reference.rows());
  double worst = 0.0;
  for (const auto& name : reference.names()) {
    const auto& r = reference.Column(name);
    const auto& f = fast.Column(name);
    double scale = 0.0, deviation = 0.0;
    for (std::size_t k = 0; k < r.size(); ++k) {
      scale = std::max(scale, std::abs(r[k]));
      deviation = std::max(deviation, std::abs(f[k] - r[k]));
    }
    const double relative = scale > 0.0 ? deviation / scale : deviation;
    if (relative >= worst) {
      worst = relative;
      *where = name;
    }
  }
  return worst;
}

Trace SimulateWithEffect(Config config, const std::string& effect, const ParameterSet& values) {
  config.AddEffect(effect, values);
  Trace trace;
  const SimStatus status = RunExperiment(config, &trace);
  EXPECT_TRUE(status.ok()) << status.message;
  return trace;
}

std::string SineInput(double amplitude, double hz) {
  char input[256];
  std::snprintf(input, sizeof input,
                R"({ "type": "chirp", "amplitude": %.17g, "f0": %.17g, "f1": %.17g })", amplitude,
                hz, hz);
  return input;
}

}  // namespace blmd::testing
