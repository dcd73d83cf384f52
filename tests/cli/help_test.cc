// The end of every command's --help (apps/common/help.h, docs/cli.md): the exit codes, each
// with what it means for that command, and worked examples that run as written. Every "$ "
// line of the footer is run by bash from a folder that holds the repository's configs/ and
// testdata/, with the built commands on PATH, and must exit 0 (the examples of one command
// in order: a later one may read what an earlier one wrote).
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/version.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::BinPath;
using testing::CommandResult;
using testing::SourcePath;
using testing::TempDir;

// The lines of `text` that start with `prefix` after their indentation, without it.
std::vector<std::string> LinesAfter(const std::string& text, const std::string& prefix) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const auto start = line.find_first_not_of(' ');
    if (start != std::string::npos && line.compare(start, prefix.size(), prefix) == 0)
      lines.push_back(line.substr(start + prefix.size()));
  }
  return lines;
}

struct Expected {
  std::string command;
  std::vector<std::string> codes;  // the exit codes the footer explains
};

TEST(HelpFooter, ExitCodesAndExamplesOfEveryCommand) {
  for (const Expected& expected :
       {Expected{"blmd-sim", {"0", "1", "2"}}, Expected{"blmd-ident", {"0", "1", "2", "3"}},
        Expected{"blmd-surface", {"0", "1", "2"}}, Expected{"blmd-tune", {"0", "1", "2"}},
        Expected{"blmd-design", {"0", "1", "2"}}, Expected{"blmd-export", {"0", "1", "2"}},
        Expected{"blmd-track", {"0", "1", "2", "3"}}}) {
    SCOPED_TRACE(expected.command);
    const CommandResult help = testing::Run(BinPath(expected.command) + " --help");
    ASSERT_EQ(help.exit_code, 0) << help.err;
    EXPECT_EQ(help.err, "");
    // The footer closes the help: the exit codes, then the examples.
    const auto status = help.out.find("\nExit status:\n");
    const auto examples = help.out.find("\nExamples:\n");
    ASSERT_NE(status, std::string::npos) << help.out;
    ASSERT_NE(examples, std::string::npos) << help.out;
    EXPECT_LT(help.out.find("Options:"), status);
    EXPECT_LT(status, examples);
    const std::string exit_part = help.out.substr(status, examples - status);
    std::vector<std::string> codes;
    std::istringstream in(exit_part);
    for (std::string line; std::getline(in, line);) {
      if (line.size() > 5 && line.compare(0, 2, "  ") == 0 && line.compare(3, 2, "  ") == 0)
        codes.push_back(line.substr(2, 1));
    }
    EXPECT_EQ(codes, expected.codes) << exit_part;

    const std::vector<std::string> commands = LinesAfter(help.out.substr(examples), "$ ");
    EXPECT_GE(commands.size(), 2u);
    TempDir dir;
    std::filesystem::create_directory_symlink(SourcePath("configs"), dir.File("configs"));
    std::filesystem::create_directory_symlink(SourcePath("testdata"), dir.File("testdata"));
    const std::string bin_dir = std::filesystem::path(BinPath(expected.command)).parent_path();
    for (std::size_t k = 0; k < commands.size(); ++k) {
      SCOPED_TRACE(commands[k]);
      EXPECT_EQ(commands[k].rfind("blmd-", 0), 0u);  // as installed: by name, not a path
      const std::string script = dir.Write("example-" + std::to_string(k) + ".sh", commands[k]);
      const CommandResult run =
          testing::Run("cd " + dir.path() + " && PATH=" + bin_dir + ":\"$PATH\" bash " + script);
      EXPECT_EQ(run.exit_code, 0) << run.err;
    }
  }
}

TEST(HelpFooter, VersionOfEveryCommand) {
  for (const std::string command : {"blmd-sim", "blmd-ident", "blmd-surface", "blmd-tune",
                                    "blmd-design", "blmd-export", "blmd-track"}) {
    const CommandResult version = testing::Run(BinPath(command) + " --version");
    EXPECT_EQ(version.exit_code, 0);
    EXPECT_EQ(version.out, command + " " + kVersion + "\n");
    EXPECT_EQ(version.err, "");
  }
}

}  // namespace
}  // namespace blmd
