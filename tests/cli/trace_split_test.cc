// --split and --select (docs/cli.md §2.2, docs/trace-format.md "Several experiments in one
// file"): a file holding several runs, with a `run` column and a clock that restarts per run,
// is cut into experiments. Oracle: the bundled traces glued into one file with a run column
// and cut again must give exactly (bit for bit) the fit of the separate files; every bad
// value is exit 2 with its one exact line and nothing written.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/ident/fit/trace_input.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// The data rows of a trace CSV (the lines after its header), each prefixed "RUN,".
std::string RowsWithRun(const std::string& path, int run) {
  std::istringstream in(Slurp(path));
  std::string line, rows;
  bool header_seen = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (!header_seen) {
      header_seen = true;
      continue;
    }
    rows += std::to_string(run) + "," + line + "\n";
  }
  return rows;
}

const std::string kStep = "testdata/ganesh-noload-step.csv";  // 10001 rows, t from 0
const std::string kSquare = "testdata/ganesh-square.csv";     // 4001 rows, t from 0

// run 0 = the step trace, run 1 = the square-wave trace; the time restarts at run 1.
std::string GluedRuns(const TempDir& dir) {
  return dir.Write("runs.csv", "# two runs, the clock restarts per run\nrun,t,u,i,w,theta\n" +
                                   RowsWithRun(SourcePath(kStep), 0) +
                                   RowsWithRun(SourcePath(kSquare), 1));
}

std::string Ident(const std::string& arguments) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") + " " +
         arguments;
}

nlohmann::json RunJson(const std::string& command) {
  const CommandResult run = blmd::testing::Run(command + " --json");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  return run.exit_code == 0 ? nlohmann::json::parse(run.out) : nlohmann::json::object();
}

TEST(TraceSplit, SplitFileFitsExactlyLikeTheSeparateFiles) {
  TempDir dir;
  const std::string runs = GluedRuns(dir);
  const nlohmann::json split = RunJson(Ident("--trace " + runs + " --split run"));
  const nlohmann::json separate =
      RunJson(Ident("--trace " + SourcePath(kStep) + " --trace " + SourcePath(kSquare)));
  ASSERT_TRUE(split.contains("parameters"));
  for (const char* name : {"J", "B"}) {
    EXPECT_EQ(split["parameters"][name]["value"].get<double>(),
              separate["parameters"][name]["value"].get<double>())
        << name;
  }
  EXPECT_EQ(split["fit"]["nrmse"].get<double>(), separate["fit"]["nrmse"].get<double>());
  ASSERT_EQ(split["traces"].size(), 2u);
  EXPECT_EQ(split["traces"][0]["path"], runs + "[run=0]");
  EXPECT_EQ(split["traces"][1]["path"], runs + "[run=1]");
  EXPECT_EQ(split["traces"][0]["samples"], 10001);
  EXPECT_EQ(split["traces"][1]["samples"], 4001);
}

TEST(TraceSplit, SelectOneRunFitsExactlyLikeThatFile) {
  TempDir dir;
  const std::string runs = GluedRuns(dir);
  const nlohmann::json selected = RunJson(Ident("--trace " + runs + " --select run=1"));
  const nlohmann::json alone = RunJson(Ident("--trace " + SourcePath(kSquare)));
  ASSERT_TRUE(selected.contains("parameters"));
  EXPECT_EQ(selected["parameters"]["J"]["value"].get<double>(),
            alone["parameters"]["J"]["value"].get<double>());
  EXPECT_EQ(selected["parameters"]["B"]["value"].get<double>(),
            alone["parameters"]["B"]["value"].get<double>());
  EXPECT_EQ(selected["trace"]["path"], runs + "[run=1]");
  EXPECT_EQ(selected["trace"]["samples"], 4001);
}

TEST(TraceSplit, ValidateTakesTheSplitToo) {
  // The split applies to --validate files as well: validating on the very experiments that
  // were fitted gives exactly the fit's error.
  TempDir dir;
  const std::string runs = GluedRuns(dir);
  const nlohmann::json report =
      RunJson(Ident("--trace " + runs + " --validate " + runs + " --split run"));
  ASSERT_TRUE(report.contains("validation"));
  EXPECT_EQ(report["validation"]["nrmse"].get<double>(), report["fit"]["nrmse"].get<double>());
  EXPECT_EQ(report["validation"]["traces"].size(), 2u);
}

TEST(TraceSplit, SurfaceOverTheSplitRunsEqualsNothingNewButRecordsTheRows) {
  TempDir dir;
  const std::string runs = GluedRuns(dir);
  const std::string out = dir.File("s.csv");
  const CommandResult run = blmd::testing::Run(
      BinPath("blmd-surface") + " --config " + SourcePath("configs/ganesh-square.json") +
      " --trace " + runs + " --select run=1 --grid J=2e-5:2.5e-5:3 --quiet --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string plain_out = dir.File("p.csv");
  ASSERT_EQ(
      blmd::testing::Run(BinPath("blmd-surface") + " --config " +
                         SourcePath("configs/ganesh-square.json") + " --trace " +
                         SourcePath(kSquare) + " --grid J=2e-5:2.5e-5:3 --quiet --out " + plain_out)
          .exit_code,
      0);
  const std::string with_rows = Slurp(out), plain = Slurp(plain_out);
  EXPECT_NE(with_rows.find("# rows: --select run=1 (1 experiment)\n"), std::string::npos);
  // The same cost at every grid point: the data rows after the header are identical.
  EXPECT_EQ(with_rows.substr(with_rows.find("\nJ,")), plain.substr(plain.find("\nJ,")));
}

// Library level: the parts, their names, rows and initial states.
TEST(TraceSplit, PartsStartFromTheirOwnFirstSampleWithInitialStateTrace) {
  TempDir dir;
  const std::string path = dir.Write("r.csv",
                                     "run,t,u,w,theta\n7,0,1,0,0\n7,1,1,1,0.5\n7,2,1,2,2\n-3,0,0,5,"
                                     "10\n-3,1,0,4,15\n-3,2,0,3,19\n");
  TraceInputOptions options;
  options.split = "run";
  options.initial_from_trace = true;
  options.required = {"w"};
  const std::vector<FitTrace> parts = LoadFitTraces(path, options, {});
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].path, path + "[run=7]");
  EXPECT_EQ(parts[1].path, path + "[run=-3]");
  EXPECT_EQ(parts[1].trace.Column("t"), (std::vector<double>{0, 1, 2}));
  EXPECT_EQ(parts[1].input.values, (std::vector<double>{0, 0, 0}));
  EXPECT_EQ(parts[1].initial.w, 5.0);
  EXPECT_EQ(parts[1].initial.theta, 10.0);
  EXPECT_EQ(parts[0].sha256, parts[1].sha256);
}

TEST(TraceSplit, SelectionSyntax) {
  const RowSelection s = ParseRowSelection("run=0:9,20:,-1");
  EXPECT_EQ(s.column, "run");
  EXPECT_TRUE(s.Matches(0));
  EXPECT_TRUE(s.Matches(9));
  EXPECT_FALSE(s.Matches(9.5));
  EXPECT_TRUE(s.Matches(1e9));
  EXPECT_TRUE(s.Matches(-1));
  EXPECT_FALSE(s.Matches(-2));
  EXPECT_TRUE(ParseRowSelection("t=:5").Matches(-1e300));
  EXPECT_TRUE(ParseRowSelection("iq=-0").Matches(0.0));  // -0 == 0
}

// ---------------------------------------------------------------------------------------
// Bad values: exit 2, exactly one line, nothing on stdout, no report written.

struct BadCase {
  std::string name, csv, flags, expected;  // expected with {FILE} for the trace's path
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

class TraceSplitBad : public ::testing::TestWithParam<BadCase> {};

const std::string kThreeRuns =
    "# runs\nrun,t,u,i,w\n0,0,1,0,0\n0,1,1,1,1\n0,2,1,1,2\n1,0,2,0,0\n1,1,2,1,1\n1,2,2,1,2\n"
    "2,0,3,0,0\n2,1,3,1,1\n2,2,3,1,2\n";

TEST_P(TraceSplitBad, ExitsTwoWithOneExactLineAndWritesNothing) {
  const BadCase& c = GetParam();
  TempDir dir;
  const std::string trace = dir.Write("trace.csv", c.csv);
  const std::string report = dir.File("report.json");
  for (const std::string& command :
       {Ident("--trace " + trace + " " + c.flags + " --report " + report),
        BinPath("blmd-surface") + " --config " + SourcePath("configs/ganesh-square.json") +
            " --trace " + trace + " " + c.flags + " --grid J=1e-5:2e-5:2 --quiet --out " +
            report}) {
    SCOPED_TRACE(command);
    const CommandResult run = blmd::testing::Run(command);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(run.err, Replace(c.expected, "{FILE}", trace));
    EXPECT_EQ(run.out, "");
    EXPECT_FALSE(FileExists(report));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, TraceSplitBad,
    ::testing::Values(
        BadCase{"RunAppearsAgain",
                "run,t,u,i,w\n0,0,1,0,0\n0,1,1,1,1\n0,2,1,1,2\n1,0,2,0,0\n1,1,2,1,1\n1,2,2,1,2\n0,"
                "3,1,1,3\n",
                "--split run",
                "error: {FILE}:8:1: --split run: run = 0 appears again (its first block is lines "
                "2-4); the rows of one experiment must be an unbroken block\n"},
        BadCase{"NoSuchSplitColumn", kThreeRuns, "--split experiment",
                "error: {FILE}: --split experiment: no column 'experiment' (header has: "
                "run,t,u,i,w)\n"},
        BadCase{"SelectMatchesNothing", kThreeRuns, "--split run --select run=5:9",
                "error: {FILE}: no row matches --select run=5:9 ('run' holds 0 ... 2)\n"},
        BadCase{"SelectNoColumn", kThreeRuns, "--select trial=1",
                "error: {FILE}: --select trial=1: no column 'trial' (header has: run,t,u,i,w)\n"},
        BadCase{"SelectNotANumber", kThreeRuns, "--select run=one",
                "error: --select run=one: 'one' is not a finite number\n"},
        BadCase{"SelectNoValue", kThreeRuns, "--select run",
                "error: --select 'run': expected NAME=VALUE[,VALUE...] or NAME=LO:HI (LO or HI may "
                "be left out)\n"},
        BadCase{"SelectEmptyItem", kThreeRuns, "--select run=1,,2",
                "error: --select 'run=1,,2': expected NAME=VALUE[,VALUE...] or NAME=LO:HI (LO or "
                "HI may be left out)\n"},
        BadCase{"SelectInvertedRange", kThreeRuns, "--select t=2:1",
                "error: --select t=2:1: the range 2:1 is inverted (LO must not exceed HI)\n"},
        BadCase{"SelectKeepsTwoBlocksWithoutSplit", kThreeRuns, "--select run=0,2",
                "error: {FILE}:9:1: --select keeps the rows kept in more than one block (line 5, "
                "then line 9): one experiment must be an unbroken block of rows; narrow the "
                "selection, or cut the file with --split COLUMN\n"},
        BadCase{"SelectCutsARunInTwo", kThreeRuns, "--split run --select w=0,2",
                "error: {FILE}:5:1: --select keeps the rows with run = 0 in more than one block "
                "(line 3, then line 5): one experiment must be an unbroken block of rows; narrow "
                "the selection\n"},
        BadCase{"TimeRestartsWithoutSplit", kThreeRuns, "",
                "error: {FILE}:6:2: time 't' must strictly increase (0 follows 2)\n"},
        BadCase{
            "TimeGoesBackWithinARun",
            "run,t,u,i,w\n0,0,1,0,0\n0,1,1,1,1\n0,2,1,1,2\n1,0,2,0,0\n1,2,2,1,1\n1,1,2,1,2\n",
            "--split run",
            "error: {FILE}:7:2: time 't' must strictly increase (1 follows 2) within run = 1\n"},
        BadCase{"RunTooShort",
                "run,t,u,i,w\n0,0,1,0,0\n0,1,1,1,1\n0,2,1,1,2\n1,0,2,0,0\n1,1,2,1,1\n",
                "--split run",
                "error: {FILE}:5: [run=1] has 2 samples only (lines 5-6): a fit needs at least 3 "
                "per experiment\n"}),
    [](const ::testing::TestParamInfo<BadCase>& info) { return info.param.name; });

}  // namespace
}  // namespace blmd::testing
