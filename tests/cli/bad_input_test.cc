// Bad input through the real commands (tests/bad-input/README.md): every malformed trace
// and config in tests/bad-input is run through blmd-ident / blmd-sim / blmd-surface, which
// must exit 2 with exactly the one line of its .expected file on stderr and leave the
// output alone: an absent output stays absent, an existing one keeps its bytes and mtime,
// and no temporary is left beside it. A case whose .expected file is empty is valid input
// (exit 0). The largest cases (10 000 columns, 1 MB lines) are generated here.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string ReplaceAll(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

std::vector<std::string> FilesIn(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

enum class Kind { kTrace, kConfig };

// The commands an input of each kind goes through; {IN} is the input, {OUT} the output.
std::vector<std::string> Commands(Kind kind) {
  const std::string noload = SourcePath("configs/ganesh-noload.json");
  const std::string trace = SourcePath("testdata/ganesh-noload-step.csv");
  const std::string grid = " --grid J=1e-5:3e-5:2 --quiet --out '{OUT}'";
  if (kind == Kind::kTrace) {
    return {
        BinPath("blmd-ident") + " --config " + noload + " --trace '{IN}' --quiet --report '{OUT}'",
        BinPath("blmd-surface") + " --config " + noload + " --trace '{IN}'" + grid};
  }
  return {
      BinPath("blmd-sim") + " --config '{IN}' --quiet --out '{OUT}'",
      BinPath("blmd-surface") + " --config '{IN}' --trace " + trace + grid,
      BinPath("blmd-ident") + " --config '{IN}' --trace " + trace + " --quiet --report '{OUT}'"};
}

// Runs `input` through every command of its kind and checks the contract. `expected` is
// the exact stderr with the input's path as {FILE} and its folder as {DIR}; "" means the
// input is valid.
// An .expected file may start with a line "# only: NAME[ NAME...]" naming the commands that
// refuse the input; the others must accept it as valid (e.g. an experiment that cannot be
// run is an error for blmd-sim, which runs it, not for blmd-ident, which fits a trace).
void CheckInput(Kind kind, const std::string& input, std::string expected_template) {
  std::vector<std::string> only;
  if (expected_template.rfind("# only:", 0) == 0) {
    const std::size_t end = expected_template.find('\n');
    std::istringstream names(expected_template.substr(7, end - 7));
    for (std::string name; names >> name;) only.push_back(name);
    expected_template = end == std::string::npos ? "" : expected_template.substr(end + 1);
  }
  const std::string folder = std::filesystem::path(input).parent_path().string();
  const std::string refused =
      ReplaceAll(ReplaceAll(expected_template, "{FILE}", input), "{DIR}", folder);
  for (const std::string& command_template : Commands(kind)) {
    const std::string command = ReplaceAll(command_template, "{IN}", input);
    SCOPED_TRACE(command);
    bool refuses = only.empty();
    for (const auto& name : only)
      refuses = refuses || command.find("/" + name + " ") != std::string::npos;
    const std::string expected = refuses ? refused : "";
    if (expected.empty()) {  // valid input: the command succeeds and writes its output
      TempDir dir;
      const std::string out = dir.File("out");
      const CommandResult run = blmd::testing::Run(ReplaceAll(command, "{OUT}", out));
      EXPECT_EQ(run.exit_code, 0) << run.err;
      EXPECT_EQ(run.err, "");
      EXPECT_TRUE(FileExists(out));
      EXPECT_EQ(FilesIn(dir.path()), std::vector<std::string>{"out"});
      continue;
    }
    {  // No output yet: none afterwards, and nothing else in the folder.
      TempDir dir;
      const std::string out = dir.File("out");
      const CommandResult run = blmd::testing::Run(ReplaceAll(command, "{OUT}", out));
      EXPECT_EQ(run.exit_code, 2) << run.err;
      EXPECT_EQ(run.err, expected);
      EXPECT_EQ(run.out, "");
      EXPECT_EQ(FilesIn(dir.path()), std::vector<std::string>{});
    }
    {  // An output from an earlier run: the same bytes and the same mtime afterwards.
      TempDir dir;
      const std::string out = dir.Write("out", "previous output\n");
      const struct timespec old_time[2] = {{1000000000, 123456789}, {1000000000, 123456789}};
      ASSERT_EQ(utimensat(AT_FDCWD, out.c_str(), old_time, 0), 0);
      const CommandResult run = blmd::testing::Run(ReplaceAll(command, "{OUT}", out));
      EXPECT_EQ(run.exit_code, 2) << run.err;
      EXPECT_EQ(run.err, expected);
      EXPECT_EQ(Slurp(out), "previous output\n");
      struct stat info {};
      ASSERT_EQ(stat(out.c_str(), &info), 0);
      EXPECT_EQ(info.st_mtim.tv_sec, 1000000000);
      EXPECT_EQ(info.st_mtim.tv_nsec, 123456789);
      EXPECT_EQ(FilesIn(dir.path()), std::vector<std::string>{"out"});
    }
  }
}

// ---------------------------------------------------------------------------------------
// The committed cases: tests/bad-input/{traces,configs}/NN-name.{csv,json} + NN-name.expected.

struct FileCase {
  std::string test_name;  // "traces_01_empty"
  Kind kind = Kind::kTrace;
  std::string input;     // absolute path
  std::string expected;  // path of the .expected file
};

std::vector<FileCase> FileCases() {
  std::vector<FileCase> cases;
  for (const auto& [folder, kind, extension] :
       {std::tuple<std::string, Kind, std::string>{"traces", Kind::kTrace, ".csv"},
        {"configs", Kind::kConfig, ".json"}}) {
    const std::string root = SourcePath("tests/bad-input/" + folder);
    for (const std::string& name : FilesIn(root)) {
      if (name.size() <= extension.size() ||
          name.compare(name.size() - extension.size(), extension.size(), extension) != 0) {
        continue;
      }
      const std::string stem = name.substr(0, name.size() - extension.size());
      FileCase c;
      c.test_name = folder + "_" + stem;
      std::replace_if(
          c.test_name.begin(), c.test_name.end(),
          [](char ch) { return !std::isalnum(static_cast<unsigned char>(ch)); }, '_');
      c.kind = kind;
      c.input = root + "/" + name;
      c.expected = root + "/" + stem + ".expected";
      cases.push_back(c);
    }
  }
  return cases;
}

class BadInputFile : public ::testing::TestWithParam<FileCase> {};

TEST_P(BadInputFile, ExitsTwoWithItsOneLineAndLeavesTheOutputAlone) {
  const FileCase& c = GetParam();
  ASSERT_TRUE(FileExists(c.expected)) << c.input << " has no .expected file";
  CheckInput(c.kind, c.input, Slurp(c.expected));
}

INSTANTIATE_TEST_SUITE_P(Cases, BadInputFile, ::testing::ValuesIn(FileCases()),
                         [](const ::testing::TestParamInfo<FileCase>& info) {
                           return info.param.test_name;
                         });

TEST(BadInputFiles, ThereAreAtLeastThirtyTracesAndFifteenConfigsAndValidCasesToo) {
  int traces = 0, configs = 0, valid = 0;
  for (const FileCase& c : FileCases()) {
    const bool is_valid = Slurp(c.expected).empty();
    valid += is_valid;
    if (!is_valid) (c.kind == Kind::kTrace ? traces : configs) += 1;
  }
  EXPECT_GE(traces, 30);
  EXPECT_GE(configs, 15);
  EXPECT_GE(valid, 2);  // -0 and irregular time stamps are valid input
}

// ---------------------------------------------------------------------------------------
// Generated cases: too large to commit, or not files at all.

const std::string kHeader = "t,u,i,w\n";
const std::string kRow = "0,24,0,0\n";

TEST(BadInputGenerated, TenThousandFieldsInADataRow) {
  TempDir dir;
  std::string line = "0.0001";
  for (int k = 1; k < 10000; ++k) line += ",1";
  const std::string input = dir.Write("wide-row.csv", kHeader + kRow + line + "\n");
  CheckInput(Kind::kTrace, input, "error: {FILE}:3:5: too many fields: the header has 4 columns\n");
}

TEST(BadInputGenerated, TenThousandColumnsInTheHeader) {
  TempDir dir;
  std::string header = "c1", row = "0";
  for (int k = 2; k <= 10000; ++k) {
    header += ",c" + std::to_string(k);
    row += ",0";
  }
  const std::string input = dir.Write("wide-header.csv", header + "\n" + row + "\n");
  CheckInput(Kind::kTrace, input,
             "error: {FILE}: missing required column 't' (header has: "
             "c1,c2,c3,c4,c5,c6,c7,c8,c9,c10,c11,c12,c13,c14,c15,c16,c17,c18,c19,c20,c21,c22,"
             "... (10000 columns); map another header with --column t=HEADER)\n");
}

TEST(BadInputGenerated, OneMegabyteNumber) {
  TempDir dir;
  const std::string input = dir.Write(
      "long-number.csv", kHeader + kRow + "0.0001,24," + std::string(1 << 20, '7') + ",0\n");
  CheckInput(Kind::kTrace, input,
             "error: {FILE}:3:3: column 'i' value "
             "\"7777777777777777777777777777777777777777...\" is out of the double range\n");
}

TEST(BadInputGenerated, OneMegabyteLineWithoutCommas) {
  TempDir dir;
  const std::string input =
      dir.Write("long-line.csv", kHeader + kRow + std::string(1 << 20, 'x') + "\n");
  CheckInput(Kind::kTrace, input,
             "error: {FILE}:3:1: column 't' is not a number "
             "(\"xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx...\")\n");
}

TEST(BadInputGenerated, OneMegabyteColumnName) {
  TempDir dir;
  const std::string input = dir.Write("long-name.csv", std::string(1 << 20, 'n') + "\n0\n");
  CheckInput(Kind::kTrace, input,
             "error: {FILE}: missing required column 't' (header has: "
             "nnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnn...; map another header with --column "
             "t=HEADER)\n");
}

TEST(BadInputGenerated, FoldersAndMissingFiles) {
  TempDir dir;
  std::filesystem::create_directory(dir.File("folder.csv"));
  std::filesystem::create_directory(dir.File("folder.json"));
  CheckInput(Kind::kTrace, dir.File("folder.csv"), "error: {FILE}: cannot read: Is a directory\n");
  CheckInput(Kind::kTrace, dir.File("absent.csv"),
             "error: {FILE}: cannot read: No such file or directory\n");
  CheckInput(Kind::kConfig, dir.File("folder.json"),
             "error: {FILE}: cannot read: Is a directory\n");
  CheckInput(Kind::kConfig, dir.File("absent.json"),
             "error: {FILE}: cannot read: No such file or directory\n");
}

}  // namespace
}  // namespace blmd::testing
