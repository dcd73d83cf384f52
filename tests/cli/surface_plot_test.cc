// blmd-surface plot: drawing a surface CSV (unsharded, merged or one shard) gives the same
// SVG as --svg on the unsharded run; malformed files are exit 2 with file:line[:column] and
// nothing written. Runs the real binary on real files.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Surface(const std::string& config, const std::string& trace, const std::string& rest) {
  return BinPath("blmd-surface") + " --config " + config + " --trace " + trace + " " + rest;
}

// The summary lines from "  grid minimum:" up to (not including) "  svg:".
std::string MinimaLines(const std::string& out) {
  const auto begin = out.find("  grid minimum:");
  if (begin == std::string::npos) return "(no grid minimum line)";
  const auto end = out.find("  svg:", begin);
  return out.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

// Runs the unsharded sweep with --svg, the same sweep in `shards` shards, merges them, plots
// the merged CSV with `title`, and checks that the two SVGs (and the minima) are identical.
void ExpectMergedPlotEqualsSvg(const std::string& config, const std::string& trace,
                               const std::string& sweep, int shards, const std::string& title,
                               std::string* svg_out) {
  TempDir dir;
  const CommandResult whole = blmd::testing::Run(
      Surface(config, trace,
              sweep + " --out " + dir.File("whole.csv") + " --svg " + dir.File("whole.svg")));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  std::string parts;
  for (int k = shards; k >= 1; --k) {
    const std::string part = dir.File("part" + std::to_string(k) + ".csv");
    const CommandResult run =
        blmd::testing::Run(Surface(config, trace,
                                   sweep + " --quiet --shard " + std::to_string(k) + "/" +
                                       std::to_string(shards) + " --out " + part));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    parts += " " + part;
  }
  const CommandResult merge = blmd::testing::Run(BinPath("blmd-surface") + " merge" + parts +
                                                 " --out " + dir.File("merged.csv"));
  ASSERT_EQ(merge.exit_code, 0) << merge.err;
  const CommandResult plot =
      blmd::testing::Run(BinPath("blmd-surface") + " plot " + dir.File("merged.csv") + " --svg " +
                         dir.File("plotted.svg") + " --title '" + title + "'");
  ASSERT_EQ(plot.exit_code, 0) << plot.err;
  EXPECT_EQ(plot.err, "");
  const std::string expected = Slurp(dir.File("whole.svg"));
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(Slurp(dir.File("plotted.svg")), expected);
  EXPECT_EQ(MinimaLines(plot.out), MinimaLines(whole.out));
  *svg_out = expected;
}

TEST(SurfacePlot, MergedTwoDimensionalSurfaceGivesTheSameSvgAsTheUnshardedRun) {
  std::string svg;
  ExpectMergedPlotEqualsSvg(SourcePath("configs/ganesh-noload.json"),
                            SourcePath("testdata/ganesh-noload-step.csv"),
                            "--grid J=log:1e-5:5e-5:7 --grid B=log:1e-5:5e-5:5", 3,
                            "ganesh-noload: cost over J, B (observe i,w)", &svg);
  std::size_t cells = 0;
  for (auto at = svg.find("class=\"cell\""); at != std::string::npos;
       at = svg.find("class=\"cell\"", at + 1))
    ++cells;
  EXPECT_EQ(cells, 35u);
}

// The BLMD current feedback over J (the paper's Fig. 8, coarse): units from the blmd model.
TEST(SurfacePlot, MergedOneDimensionalBlmdSurfaceGivesTheSameSvgAsTheUnshardedRun) {
  std::string svg;
  ExpectMergedPlotEqualsSvg(
      SourcePath("configs/blmd-d31x.json"), SourcePath("testdata/blmd-d31x-step.csv"),
      "--observe i --grid J=8.33e-4:1.547e-3:13", 2, "blmd-d31x: cost over J (observe i)", &svg);
  EXPECT_NE(svg.find("J (kg·m²)"), std::string::npos);
}

TEST(SurfacePlot, DefaultTitleNamesTheFileAndAShardIsDrawnWithItsSliceOnly) {
  TempDir dir;
  const std::string sweep = "--grid J=log:1e-5:5e-5:7 --grid B=log:1e-5:5e-5:5 --quiet";
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string trace = SourcePath("testdata/ganesh-noload-step.csv");
  ASSERT_EQ(
      blmd::testing::Run(Surface(config, trace, sweep + " --out " + dir.File("s.csv"))).exit_code,
      0);
  ASSERT_EQ(blmd::testing::Run(
                Surface(config, trace, sweep + " --shard 2/3 --out " + dir.File("part2.csv")))
                .exit_code,
            0);

  const CommandResult whole = blmd::testing::Run(BinPath("blmd-surface") + " plot " +
                                                 dir.File("s.csv") + " --svg " + dir.File("s.svg"));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_NE(Slurp(dir.File("s.svg")).find(">s.csv: cost over J, B (observe i,w)</text>"),
            std::string::npos);

  // Shard 2/3 of 35 points holds grid indices 11..22; the rest are drawn as gaps.
  const CommandResult shard =
      blmd::testing::Run(BinPath("blmd-surface") + " plot " + dir.File("part2.csv") + " --svg " +
                         dir.File("part2.svg"));
  ASSERT_EQ(shard.exit_code, 0) << shard.err;
  EXPECT_EQ(shard.out.substr(0, shard.out.find('\n') + 1),
            "blmd-surface: plotted 12 points (shard 2/3 of 35) of " + dir.File("part2.csv") +
                " -> " + dir.File("part2.svg") + "\n");
  const std::string svg = Slurp(dir.File("part2.svg"));
  EXPECT_NE(svg.find(">part2.csv: cost over J, B (observe i,w), shard 2/3</text>"),
            std::string::npos);
  std::size_t cells = 0;
  for (auto at = svg.find("class=\"cell\""); at != std::string::npos;
       at = svg.find("class=\"cell\"", at + 1))
    ++cells;
  EXPECT_EQ(cells, 35u);

  const CommandResult quiet =
      blmd::testing::Run(BinPath("blmd-surface") + " plot " + dir.File("s.csv") + " --svg " +
                         dir.File("q.svg") + " --quiet");
  EXPECT_EQ(quiet.exit_code, 0);
  EXPECT_EQ(quiet.out, "");
  EXPECT_EQ(Slurp(dir.File("q.svg")), Slurp(dir.File("s.svg")));
}

// A small hand-written surface: 3 points over J, local minimum in the middle.
const char* const kValid =
    "# blmd-surface 0.1.0\n"   // line 1
    "# model: dc_servo\n"      // 2
    "# observe: i,w\n"         // 3
    "# grid: J=0.25:0.75:3\n"  // 4
    "J,mse_i,mse_w,cost\n"     // 5
    "0.25,0.5,0.25,0.375\n"    // 6
    "0.5,0.01,0.02,0.015\n"    // 7
    "0.75,0.4,0.3,0.35\n";     // 8

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) return "(pattern '" + from + "' not found)";
  return text.replace(at, from.size(), to);
}

TEST(SurfacePlot, HandWrittenSurfaceIsPlottedWithItsLocalMinimum) {
  TempDir dir;
  const std::string csv = dir.Write("hand.csv", kValid);
  const CommandResult run = blmd::testing::Run(BinPath("blmd-surface") + " plot " + csv +
                                               " --svg " + dir.File("hand.svg"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, "blmd-surface: plotted 3 points of " + csv + " -> " + dir.File("hand.svg") +
                         "\n"
                         "  grid minimum: J = 0.5, cost 0.015\n"
                         "  local minima: 1\n"
                         "    J = 0.5, cost 0.015  (global)\n");
  const std::string svg = Slurp(dir.File("hand.svg"));
  EXPECT_NE(svg.find("J (kg·m²)"), std::string::npos);  // dc_servo's unit for J
  EXPECT_NE(svg.find("class=\"global-min\" data-index=\"1\" data-x=\"0.5\""), std::string::npos);

  // A failed point ("inf", empty mse) is allowed and counted.
  const std::string failed =
      dir.Write("failed.csv", Replace(kValid, "0.75,0.4,0.3,0.35", "0.75,,,inf"));
  const CommandResult with_gap =
      blmd::testing::Run(BinPath("blmd-surface") + " plot " + failed + " --svg " +
                         dir.File("failed.svg") + " --quiet");
  EXPECT_EQ(with_gap.exit_code, 0) << with_gap.err;
  EXPECT_NE(Slurp(dir.File("failed.svg")).find("class=\"gap\""), std::string::npos);
}

TEST(SurfacePlot, MalformedSurfaceCsvExitsTwoNamingFileAndLineAndWritesNothing) {
  TempDir dir;
  const std::string valid = kValid;
  struct Case {
    std::string name, text, where, message;
  };
  const std::vector<Case> cases = {
      {"cost.csv", Replace(valid, "0.5,0.01,0.02,0.015", "0.5,0.01,0.02,abc"), ":7:15",
       "column 'cost' is not a number >= 0 or 'inf' (\"abc\")"},
      {"negative.csv", Replace(valid, "0.5,0.01,0.02,0.015", "0.5,0.01,0.02,-1"), ":7:15",
       "column 'cost' is not a number >= 0 or 'inf' (\"-1\")"},
      {"mse.csv", Replace(valid, "0.5,0.01,0.02,0.015", "0.5,0.01,,0.015"), ":7:10",
       "column 'mse_w' is not a number >= 0 (\"\")"},
      {"coordinate.csv", Replace(valid, "0.5,0.01", "0.55,0.01"), ":7:1",
       "J = 0.55 is not the next grid point (row 2 of the grid should have J = 0.5)"},
      {"nan.csv", Replace(valid, "0.5,0.01", "nan,0.01"), ":7:1",
       "column 'J' is not a finite number (\"nan\")"},
      {"fields.csv", Replace(valid, "0.25,0.5,0.25,0.375", "0.25,0.5,0.25,0.375,9"), ":6",
       "5 fields, the header has 4"},
      {"header.csv", Replace(valid, "J,mse_i,mse_w,cost", "J,mse_i,cost"), ":5:1",
       "header 'J,mse_i,cost' does not match the grid and observe lines (expected "
       "'J,mse_i,mse_w,cost')"},
      {"truncated.csv", Replace(valid, "0.75,0.4,0.3,0.35\n", ""), ":7",
       "the file ends after 2 of the 3 points of the grid (truncated?)"},
      {"extra.csv", valid + "1,0.4,0.3,0.35\n", ":9:1", "more rows than the grid has points (3)"},
      {"nogrid.csv", Replace(valid, "# grid: J=0.25:0.75:3\n", ""), ":4",
       "not a blmd-surface CSV: no '# grid: P=LO:HI:N' line before the header"},
      {"noobserve.csv", Replace(valid, "# observe: i,w\n", ""), ":4",
       "not a blmd-surface CSV: no '# observe:' line before the header"},
      {"badgrid.csv", Replace(valid, "J=0.25:0.75:3", "J=0.25:0.75"), ":4:1",
       "bad grid line: 'J=0.25:0.75': expected P=LO:HI:N or P=log:LO:HI:N"},
      {"shard.csv", Replace(valid, "# observe:", "# shard: 4/3\n# observe:"), ":3:1",
       "bad shard line '# shard: 4/3' (expected '# shard: K/N' with 1 <= K <= N)"},
      {"empty.csv", "", "", "not a blmd-surface CSV (no header row, no '# grid:' line)"},
  };
  for (const auto& c : cases) {
    const std::string csv = dir.Write(c.name, c.text);
    const std::string svg = dir.File(c.name + ".svg");
    const CommandResult run =
        blmd::testing::Run(BinPath("blmd-surface") + " plot " + csv + " --svg " + svg);
    EXPECT_EQ(run.exit_code, 2) << c.name;
    EXPECT_EQ(run.err, "error: " + csv + c.where + ": " + c.message + "\n") << c.name;
    EXPECT_EQ(run.out, "") << c.name;
    EXPECT_FALSE(FileExists(svg)) << c.name;
  }
}

TEST(SurfacePlot, BadUsageExitsTwoAndWritesNothing) {
  TempDir dir;
  const std::string csv = dir.Write("hand.csv", kValid);
  const CommandResult no_svg = blmd::testing::Run(BinPath("blmd-surface") + " plot " + csv);
  EXPECT_EQ(no_svg.exit_code, 2);
  EXPECT_EQ(no_svg.err, "error: --svg is required (see " + BinPath("blmd-surface") + " --help)\n");
  const CommandResult missing = blmd::testing::Run(
      BinPath("blmd-surface") + " plot " + dir.File("absent.csv") + " --svg " + dir.File("a.svg"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_EQ(missing.err.rfind("error: " + dir.File("absent.csv") + ": cannot read", 0), 0u)
      << missing.err;
  EXPECT_FALSE(FileExists(dir.File("a.svg")));
}

}  // namespace
}  // namespace blmd::testing
