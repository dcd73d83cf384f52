// blmd-ident's progress line on stderr (docs/cli.md §2.3): --progress forces it (also into a
// file), --no-progress forbids it, the default shows it only on a terminal and not with
// --quiet; it never reaches stdout, so --json stays pure JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Ident(const std::string& arguments) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-noload.json") +
         " --trace " + SourcePath("testdata/ganesh-noload-step.csv") + " " + arguments;
}

std::string Discover(const std::string& arguments) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") +
         " --trace " + SourcePath("testdata/dc-hidden-coulomb.csv") + " --discover " + arguments;
}

// The count of the final line "blmd-ident: done: N evaluations, ..." (-1 when absent).
long DoneEvaluations(const std::string& err) {
  std::smatch match;
  // The time reads "12.3 s", or "1:21 min" past a minute (a slow machine, a sanitizer build).
  static const std::regex done(
      "\rblmd-ident: done: ([0-9]+) evaluations, ([0-9.]+ s|[0-9]+:[0-9]{2} min) *\n$");
  if (!std::regex_search(err, match, done)) return -1;
  return std::stol(match[1].str());
}

TEST(ProgressCli, ForcedIntoAFileItShowsTheStagesAndEndsWithTheCountAndANewline) {
  TempDir dir;
  const CommandResult run = blmd::testing::Run(Ident("--progress --report " + dir.File("r.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // Every stage drawn when it began, in order, then the final line; one newline, at the end.
  const std::size_t fit = run.err.find("\rblmd-ident: first fit (ceres): ");
  const std::size_t report = run.err.find("\rblmd-ident: report: ");
  ASSERT_NE(fit, std::string::npos) << run.err;
  ASSERT_NE(report, std::string::npos) << run.err;
  EXPECT_EQ(fit, 0u);
  EXPECT_LT(fit, report);
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  ASSERT_FALSE(run.err.empty());
  EXPECT_EQ(run.err.back(), '\n');
  // The fits (the first and the noise-weighted refits): the final count is theirs, in the
  // report.
  const auto json = nlohmann::json::parse(Slurp(dir.File("r.json")));
  const long evaluations = json["noise"]["evaluations"].get<long>();
  EXPECT_GT(evaluations, 0);
  EXPECT_EQ(DoneEvaluations(run.err), evaluations) << run.err;
  // The summary on stdout as without progress.
  EXPECT_NE(run.out.find("parameters"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("blmd-ident: "), std::string::npos) << run.out;
}

TEST(ProgressCli, JsonStaysPureJsonAndDiscoveryShowsItsRounds) {
  const CommandResult run = blmd::testing::Run(Discover("--json --progress"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // stdout: the report and nothing else.
  const auto report = nlohmann::json::parse(run.out);  // throws on anything else
  EXPECT_EQ(report["tool"], "blmd-ident");
  EXPECT_EQ(run.out.find('\r'), std::string::npos);
  EXPECT_EQ(run.out.find("evaluations, "), std::string::npos);
  // stderr: the stages of a discovery that adds coulomb_friction in round 1 and finds
  // nothing in round 2, in order, each drawn as it began: round 1 screens the 10 effects of
  // dc_servo (not asymmetric_viscous; two_mass among them, set aside where the residual does
  // not follow the input's past) and refits the best 3 and the position-dependent ones whose
  // screening lowers BIC (docs/discovery.md §3), round 2 screens the other 9; the adequacy
  // check of the final model follows.
  std::size_t at = 0;
  for (const char* stage :
       {"first fit (ceres): ", "report: ", "discovery round 1: screening 0/10: ",
        "discovery round 1: refits 0/", "discovery round 2: screening 0/9: ", "adequacy check",
        "final model: report: "}) {
    const std::size_t found = run.err.find(std::string("\rblmd-ident: ") + stage, at);
    ASSERT_NE(found, std::string::npos) << stage << " after byte " << at << ":\n" << run.err;
    at = found + 1;
  }
  EXPECT_EQ(report["discovery"]["added"], nlohmann::json::array({"coulomb_friction"}));
  // Discovery's evaluations come on top of the first fit's.
  const long total = DoneEvaluations(run.err);
  EXPECT_GT(total, report["discovery"]["before"]["fit"]["evaluations"].get<long>()) << run.err;
  EXPECT_EQ(run.err.back(), '\n');
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
}

TEST(ProgressCli, OffByDefaultWhenStderrIsNotATerminal) {
  const CommandResult run = blmd::testing::Run(Ident(""));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  EXPECT_NE(run.out.find("parameters"), std::string::npos);
}

TEST(ProgressCli, NoProgressWins) {
  for (const char* flags : {"--progress --no-progress", "--no-progress --progress"}) {
    const CommandResult run = blmd::testing::Run(Ident(flags));
    ASSERT_EQ(run.exit_code, 0) << flags << ": " << run.err;
    EXPECT_EQ(run.err, "") << flags;
  }
}

// Under a pseudo-terminal (script(1) of util-linux): stdout and stderr are the terminal.
CommandResult OnATerminal(const std::string& command) {
  std::string quoted = "'";
  for (char c : command) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  quoted += "'";
  return blmd::testing::Run("script -qec " + quoted + " /dev/null");
}

TEST(ProgressCli, OnByDefaultOnATerminalButNotWithQuietOrNoProgress) {
  if (blmd::testing::Run("command -v script").exit_code != 0)
    GTEST_SKIP() << "script (util-linux) missing";
  const CommandResult run = OnATerminal(Ident(""));
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::size_t fit = run.out.find("\rblmd-ident: first fit (ceres): ");
  const std::size_t done = run.out.find("\rblmd-ident: done: ");
  const std::size_t summary = run.out.find("parameters");
  ASSERT_NE(fit, std::string::npos) << run.out;
  ASSERT_NE(done, std::string::npos) << run.out;
  ASSERT_NE(summary, std::string::npos) << run.out;
  EXPECT_LT(fit, done);
  EXPECT_LT(done, summary);  // the line is ended before the summary is printed

  const CommandResult quiet = OnATerminal(Ident("--quiet"));
  ASSERT_EQ(quiet.exit_code, 0) << quiet.out << quiet.err;
  EXPECT_EQ(quiet.out, "");
  const CommandResult off = OnATerminal(Ident("--no-progress"));
  ASSERT_EQ(off.exit_code, 0) << off.out << off.err;
  EXPECT_EQ(off.out.find("blmd-ident: "), std::string::npos) << off.out;
  EXPECT_NE(off.out.find("parameters"), std::string::npos) << off.out;
  // --progress brings it back with --quiet.
  const CommandResult forced = OnATerminal(Ident("--quiet --progress"));
  ASSERT_EQ(forced.exit_code, 0) << forced.out << forced.err;
  EXPECT_NE(forced.out.find("\rblmd-ident: done: "), std::string::npos) << forced.out;
}

}  // namespace
}  // namespace blmd::testing
