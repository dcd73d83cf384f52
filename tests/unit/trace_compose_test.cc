// Every trace preparation flag with every other (docs/cli.md §2.2, the order in which they
// apply): --column, --scale, --derive, --select (several), --split, --initial-state,
// --delimiter, --duplicate-time, --resample, in pairs (every pair with --duplicate-time and with
// --select, --derive with --select and --split, and more). Oracle: small files whose
// prepared rows are worked out by hand (binary-exact values, so the rows compare exactly),
// or the exact error line.
#include <gtest/gtest.h>

#include <charconv>
#include <sstream>
#include <string>
#include <vector>

#include "app/request.h"
#include "blmd/error.h"
#include "blmd/ident/fit/trace_input.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// One repeated stamp at the start (lines 2-3) and one inside (lines 5-6). Merged with
// --duplicate-time mean: t 0,0.5,1,1.5,2; u 2,1,2,1,1; w 1,2,4,4,4; theta 1,3,5,7,8.
const std::string kRepeats =
    "t,u,theta,w\n0,1,0,0\n0,3,2,2\n0.5,1,3,2\n1,1,4,4\n1,3,6,4\n1.5,1,7,4\n2,1,8,4\n";
// The same with other headers for t and theta.
const std::string kNamed =
    "time,u,pos,w\n0,1,0,0\n0,3,2,2\n0.5,1,3,2\n1,1,4,4\n1,3,6,4\n1.5,1,7,4\n2,1,8,4\n";
// The same ';'-separated, with decimal commas.
const std::string kSemicolon =
    "t;u;theta;w\n0;1;0;0\n0;3;2;2\n0,5;1;3;2\n1;1;4;4\n1;3;6;4\n1,5;1;7;4\n2;1;8;4\n";
// Two runs; run 1 starts at the stamp at which run 0 ends (lines 6-7), and each repeats one
// stamp (lines 3-4, 10-11).
const std::string kRuns =
    "run,t,u,theta,w\n0,0,1,0,0\n0,0.5,1,1,2\n0,0.5,3,2,4\n0,1,1,4,4\n0,1.5,1,6,4\n"
    "1,1.5,2,10,0\n1,2,2,11,2\n1,2.5,2,13,4\n1,3,2,16,6\n1,3,4,18,6\n";

// The flags' text (as on a command line) as the settings the commands build.
TraceSettings Flags(const std::string& text) {
  TraceSettings settings;
  std::istringstream in(text);
  for (std::string flag, value; in >> flag >> value;) {
    if (flag == "--column") settings.columns.push_back(value);
    if (flag == "--scale") settings.scales.push_back(value);
    if (flag == "--derive") settings.derives.push_back(value);
    if (flag == "--select") settings.selects.push_back(value);
    if (flag == "--split") settings.split = value;
    if (flag == "--initial-state") settings.initial_state = value;
    if (flag == "--delimiter") settings.delimiter = value;
    if (flag == "--duplicate-time") settings.duplicate_time = value;
    if (flag == "--resample") settings.resample = value;
  }
  return settings;
}

std::string Numbers(const std::vector<double>& values) {
  std::string out;
  for (double v : values) {
    char buffer[32];
    out +=
        (out.empty() ? "" : ",") + std::string(buffer, std::to_chars(buffer, buffer + 32, v).ptr);
  }
  return out;
}

// The experiments as one line each: the name after the file's path, the standard columns,
// the initial state; or the error's text with the path as FILE.
std::string Prepared(const std::string& csv, const std::string& flags) {
  TempDir dir;
  const std::string path = dir.Write("trace.csv", csv);
  std::string out;
  try {
    for (const FitTrace& part : LoadFitTraces(path, Flags(flags).Options({}, false), {})) {
      out += part.path.substr(path.size());
      for (const char* name : {"t", "u", "i", "w", "theta", "open"}) {
        if (part.trace.Has(name))
          out += std::string(" ") + name + "=" + Numbers(part.trace.Column(name));
      }
      out += " init=" + Numbers({part.initial.w, part.initial.theta}) + "\n";
    }
  } catch (const InputError& error) {
    out = error.what();
    for (std::size_t at = out.find(path); at != std::string::npos; at = out.find(path)) {
      out.replace(at, path.size(), "FILE");
    }
  }
  return out;
}

// The MG996R servo log's case (27 repeated stamps): --select t=0: with --duplicate-time
// mean left the repeats in (the selection made the reader skip its time check, and with it
// the merging), so the fit's own time check refused the file without the flag's hint.
TEST(TraceCompose, DuplicateTimeAppliesWithSelect) {
  EXPECT_EQ(Prepared(kRepeats, "--select t=0: --duplicate-time mean"),
            "[t=0:] t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n");
  EXPECT_EQ(Prepared(kRepeats, "--select t=0:"),
            "FILE:3:1: time 't' must strictly increase (0 repeats 0 of line 2); for several "
            "rows logged at one instant use --duplicate-time first|mean");
}

struct Case {
  std::string csv;
  std::string flags, expected;
};

TEST(TraceCompose, EveryPairOfFlags) {
  const std::vector<Case> cases = {
      // --duplicate-time alone, and with every other flag.
      {kRepeats, "--duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      {kRepeats, "--duplicate-time first",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 w=0,2,4,4,4 theta=0,3,4,7,8 init=0,0\n"},
      {kRepeats, "--select t=0: --duplicate-time mean",
       "[t=0:] t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      {kRepeats, "--select t=0:",
       "FILE:3:1: time 't' must strictly increase (0 repeats 0 of line 2); for several rows "
       "logged at one instant use --duplicate-time first|mean"},
      // The selection drops line 2 (w = 0): the instant t = 0 is line 3 alone, not averaged
      // with the dropped row.
      {kRepeats, "--select w=2: --duplicate-time mean",
       "[w=2:] t=0,0.5,1,1.5,2 u=3,1,2,1,1 w=2,2,4,4,4 theta=2,3,5,7,8 init=0,0\n"},
      // A selection that drops one row inside an instant breaks the block.
      {kRepeats, "--select u=1 --duplicate-time mean",
       "FILE:4:1: --select keeps the rows kept in more than one block (line 2, then line 4): "
       "one experiment must be an unbroken block of rows; narrow the selection, or cut the "
       "file with --split COLUMN"},
      // Within each run: the last row of run 0 and the first of run 1 share t = 1.5 and stay
      // apart; without --split they are one instant of one experiment, merged.
      {kRuns, "--split run --duplicate-time mean",
       "[run=0] t=0,0.5,1,1.5 u=1,2,1,1 w=0,3,4,4 theta=0,1.5,4,6 init=0,0\n"
       "[run=1] t=1.5,2,2.5,3 u=2,2,2,3 w=0,2,4,6 theta=10,11,13,17 init=0,0\n"},
      {kRuns, "--duplicate-time mean",
       " t=0,0.5,1,1.5,2,2.5,3 u=1,2,1,1.5,2,2,3 w=0,3,4,2,2,4,6 theta=0,1.5,4,8,11,13,17 "
       "init=0,0\n"},
      {kRuns, "--split run",
       "FILE:4:2: time 't' must strictly increase (0.5 repeats 0.5 of line 3) within run = 0; "
       "for several rows logged at one instant use --duplicate-time first|mean"},
      {kNamed, "--column t=time --column theta=pos --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      {kNamed, "--column t=time --column theta=pos",
       "FILE:3:1: time 'time' must strictly increase (0 repeats 0 of line 2); for several rows "
       "logged at one instant use --duplicate-time first|mean"},
      {kRepeats, "--scale t=2 --scale u=0.5 --duplicate-time mean",
       " t=0,1,2,3,4 u=1,0.5,1,0.5,0.5 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      {kRepeats, "--derive w=theta --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=4,4,4,3,2 theta=1,3,5,7,8 init=0,0\n"},
      {kRepeats, "--initial-state trace --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=1,1\n"},
      {kSemicolon, "--delimiter ; --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      // --select with the others.
      {kRepeats, "--select t=0.5: --select t=:1.5 --duplicate-time first",
       "[t=0.5:,t=:1.5] t=0.5,1,1.5 u=1,1,1 w=2,4,4 theta=3,4,7 init=0,0\n"},
      {kRuns, "--select run=1 --select t=:2.5",
       "[run=1,t=:2.5] t=1.5,2,2.5 u=2,2,2 w=0,2,4 theta=10,11,13 init=0,0\n"},
      {kNamed, "--column t=time --column theta=pos --select t=1: --duplicate-time mean",
       "[t=1:] t=1,1.5,2 u=2,1,1 w=4,4,4 theta=5,7,8 init=0,0\n"},
      {kNamed, "--column t=time --select time=1: --duplicate-time first",
       "[time=1:] t=1,1.5,2 u=1,1,1 w=4,4,4 init=0,0\n"},
      {kRepeats, "--scale t=2 --select t=2: --duplicate-time mean",
       "[t=2:] t=2,3,4 u=2,1,1 w=4,4,4 theta=5,7,8 init=0,0\n"},
      {kRuns, "--select run=1 --select t=:2.5 --derive w=theta",
       "[run=1,t=:2.5] t=1.5,2,2.5 u=2,2,2 w=2,3,4 theta=10,11,13 init=0,0\n"},
      {kRepeats, "--select t=0.5: --derive w=theta --duplicate-time mean",
       "[t=0.5:] t=0.5,1,1.5,2 u=1,2,1,1 w=4,4,3,2 theta=3,5,7,8 init=0,0\n"},
      {kRuns, "--split run --select t=0.5:2.5 --duplicate-time mean",
       "[run=0] t=0.5,1,1.5 u=2,1,1 w=3,4,4 theta=1.5,4,6 init=0,0\n"
       "[run=1] t=1.5,2,2.5 u=2,2,2 w=0,2,4 theta=10,11,13 init=0,0\n"},
      {kRepeats, "--select t=1: --initial-state trace --duplicate-time mean",
       "[t=1:] t=1,1.5,2 u=2,1,1 w=4,4,4 theta=5,7,8 init=4,5\n"},
      {kSemicolon, "--delimiter ; --select t=1: --duplicate-time first",
       "[t=1:] t=1,1.5,2 u=1,1,1 w=4,4,4 theta=4,7,8 init=0,0\n"},
      // --derive with --split, and the remaining pairs.
      {kRuns, "--split run --derive w=theta --duplicate-time mean",
       "[run=0] t=0,0.5,1,1.5 u=1,2,1,1 w=3,4,4.5,4 theta=0,1.5,4,6 init=0,0\n"
       "[run=1] t=1.5,2,2.5,3 u=2,2,2,3 w=2,3,6,8 theta=10,11,13,17 init=0,0\n"},
      {kRuns, "--split run --initial-state trace --duplicate-time mean",
       "[run=0] t=0,0.5,1,1.5 u=1,2,1,1 w=0,3,4,4 theta=0,1.5,4,6 init=0,0\n"
       "[run=1] t=1.5,2,2.5,3 u=2,2,2,3 w=0,2,4,6 theta=10,11,13,17 init=0,10\n"},
      {kNamed, "--column t=time --column theta=pos --scale theta=0.5 --duplicate-time first",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 w=0,2,4,4,4 theta=0,1.5,2,3.5,4 init=0,0\n"},
      {kNamed, "--column t=time --column theta=pos --derive w=theta --duplicate-time first",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 w=6,4,4,4,2 theta=0,3,4,7,8 init=0,0\n"},
      {kRepeats, "--scale theta=2 --derive w=theta --duplicate-time first",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 w=12,8,8,8,4 theta=0,6,8,14,16 init=0,0\n"},
      {kRepeats, "--derive w=theta --initial-state trace --duplicate-time first",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 w=6,4,4,4,2 theta=0,3,4,7,8 init=6,0\n"},
      // Time going back stays an error, checked after scaling and merging; the line is the
      // file's although rows before it were merged.
      {kRepeats, "--scale t=-1 --duplicate-time mean",
       "FILE:4:1: time 't' must strictly increase (-0.5 follows 0)"},
      // A selection across the runs without --split: one experiment, whose instant t = 1.5
      // holds the last row of run 0 and the first of run 1 (first: run 0's).
      {kRuns, "--select t=1: --duplicate-time first",
       "[t=1:] t=1,1.5,2,2.5,3 u=1,1,2,2,2 w=4,4,2,4,6 theta=4,6,11,13,16 init=0,0\n"},
      {kSemicolon, "--delimiter ; --derive w=theta --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=4,4,4,3,2 theta=1,3,5,7,8 init=0,0\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.flags);
    EXPECT_EQ(Prepared(c.csv, c.flags), c.expected);
  }
}

// A gap of 7 s in 1 s steps.
const std::string kGap = "t,u,theta\n0,0,0\n1,1,1\n2,2,4\n3,3,9\n10,4,16\n11,5,25\n12,6,36\n";

// --resample with every other flag: linear interpolation onto the grid from the first
// stamp, after merging and before --derive and --initial-state; gaps over 5 steps cut.
TEST(TraceCompose, ResampleWithEveryFlag) {
  const std::vector<Case> cases = {
      // kRepeats merged (t 0,0.5,1,1.5,2) onto steps of 0.25.
      {kRepeats, "--resample 0.25 --duplicate-time mean",
       " t=0,0.25,0.5,0.75,1,1.25,1.5,1.75,2 u=2,1.5,1,1.5,2,1.5,1,1,1 w=1,1.5,2,3,4,4,4,4,4 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=0,0\n"},
      // auto: the median step (0.5), the merged samples themselves.
      {kRepeats, "--resample auto --duplicate-time mean",
       " t=0,0.5,1,1.5,2 u=2,1,2,1,1 w=1,2,4,4,4 theta=1,3,5,7,8 init=0,0\n"},
      {kRepeats, "--resample 0.25",
       "FILE:3:1: time 't' must strictly increase (0 repeats 0 of line 2); for several rows "
       "logged at one instant use --duplicate-time first|mean"},
      // --derive differentiates the grid's samples.
      {kRepeats, "--resample 0.25 --derive w=theta --duplicate-time mean",
       " t=0,0.25,0.5,0.75,1,1.25,1.5,1.75,2 u=2,1.5,1,1.5,2,1.5,1,1,1 w=4,4,4,4,4,4,3,2,2 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=0,0\n"},
      {kRepeats, "--select t=0.5: --resample 0.25 --duplicate-time mean",
       "[t=0.5:] t=0.5,0.75,1,1.25,1.5,1.75,2 u=1,1.5,2,1.5,1,1,1 w=2,3,4,4,4,4,4 "
       "theta=3,4,5,6,7,7.5,8 init=0,0\n"},
      {kRuns, "--split run --resample 0.25 --duplicate-time mean",
       "[run=0] t=0,0.25,0.5,0.75,1,1.25,1.5 u=1,1.5,2,1.5,1,1,1 w=0,1.5,3,3.5,4,4,4 "
       "theta=0,0.75,1.5,2.75,4,5,6 init=0,0\n"
       "[run=1] t=1.5,1.75,2,2.25,2.5,2.75,3 u=2,2,2,2,2,2.5,3 w=0,1,2,3,4,5,6 "
       "theta=10,10.5,11,12,13,15,17 init=0,0\n"},
      {kRepeats, "--resample 0.25 --initial-state trace --duplicate-time mean",
       " t=0,0.25,0.5,0.75,1,1.25,1.5,1.75,2 u=2,1.5,1,1.5,2,1.5,1,1,1 w=1,1.5,2,3,4,4,4,4,4 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=1,1\n"},
      {kNamed, "--column t=time --column theta=pos --resample 0.25 --duplicate-time mean",
       " t=0,0.25,0.5,0.75,1,1.25,1.5,1.75,2 u=2,1.5,1,1.5,2,1.5,1,1,1 w=1,1.5,2,3,4,4,4,4,4 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=0,0\n"},
      // The step is in the units of the scaled t.
      {kRepeats, "--scale t=2 --resample 0.5 --duplicate-time mean",
       " t=0,0.5,1,1.5,2,2.5,3,3.5,4 u=2,1.5,1,1.5,2,1.5,1,1,1 w=1,1.5,2,3,4,4,4,4,4 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=0,0\n"},
      {kSemicolon, "--delimiter ; --resample 0.25 --duplicate-time mean",
       " t=0,0.25,0.5,0.75,1,1.25,1.5,1.75,2 u=2,1.5,1,1.5,2,1.5,1,1,1 w=1,1.5,2,3,4,4,4,4,4 "
       "theta=1,2,3,4,5,6,7,7.5,8 init=0,0\n"},
      // A gap longer than 5 steps cuts the experiment: no samples are made up across it.
      {kGap, "--resample 0.5",
       "[t=0:3] t=0,0.5,1,1.5,2,2.5,3 u=0,0.5,1,1.5,2,2.5,3 theta=0,0.5,1,2.5,4,6.5,9 "
       "init=0,0\n"
       "[t=10:12] t=10,10.5,11,11.5,12 u=4,4.5,5,5.5,6 theta=16,20.5,25,30.5,36 init=0,0\n"},
      {kGap, "--resample auto --initial-state trace --select t=1:",
       "[t=1:][t=1:3] t=1,2,3 u=1,2,3 theta=1,4,9 init=0,1\n"
       "[t=1:][t=10:12] t=10,11,12 u=4,5,6 theta=16,25,36 init=0,16\n"},
      // 7 s is not over 5 steps of 2 s: interpolated across.
      {kGap, "--resample 2",
       " t=0,2,4,6,8,10,12 u=0,2,3.142857142857143,3.4285714285714284,3.7142857142857144,4,6 "
       "theta=0,4,10,12,14,16,36 init=0,0\n"},
      {kGap, "--resample 1 --select t=:10.5",
       "FILE:6: [t=:10.5][t=10:10] has 1 sample only (line 6): a fit needs at least 3 per "
       "experiment"},
      // `open` (the armature switch) is held, not interpolated.
      {"t,u,open\n0,1,0\n1,1,1\n2,1,1\n", "--resample 0.5",
       " t=0,0.5,1,1.5,2 u=1,1,1,1,1 open=0,0,1,1,1 init=0,0\n"},
      {kRepeats, "--resample 0.001 --duplicate-time mean",
       "FILE: --resample 0.001 is less than 1/5 of the median step, 0.5 s: every recorded step "
       "would be a gap; choose a step near the median step (--resample auto)"},
      {kRepeats, "--resample 0 --duplicate-time mean",
       "--resample: expected a step in seconds > 0, or auto (the median step), not '0'"},
      {kRepeats, "--resample median",
       "--resample: expected a step in seconds > 0, or auto (the median step), not 'median'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.flags);
    EXPECT_EQ(Prepared(c.csv, c.flags), c.expected);
  }
  // Recorded in a surface CSV's rows line, with the other flags that change the rows.
  EXPECT_EQ(Flags("--select t=1: --duplicate-time mean --resample auto --split run").RowsLine(),
            " --select t=1: --split run --duplicate-time mean --resample auto");
}

}  // namespace
}  // namespace blmd::testing
