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

CommandResult Run(const std::string& command_line) {
  TempDir capture;
  const std::string out = capture.File("stdout"), err = capture.File("stderr");
  const std::string full = "(" + command_line + ") >" + out + " 2>" + err + " </dev/null";
  const int status = std::system(full.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = Slurp(out);
  result.err = Slurp(err);
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

}  // namespace blmd::testing
