// blmd-surface: the paper's Figs. 8-9 shapes, exactness of the grid minimum, shards,
// threads, and bad input. Runs the real binary on real files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Surface(const std::string& config, const std::string& trace, const std::string& rest) {
  return BinPath("blmd-surface") + " --config " + config + " --trace " + trace + " " + rest;
}

TEST(Surface, NoiseFreeGridMinimumIsAtTheTrueJAndB) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string trace = dir.File("clean.csv");
  ASSERT_EQ(blmd::testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + trace +
                               " --quiet")
                .exit_code,
            0);
  // 2.26e-5 and 2.261e-5 are interior grid points (index 5 of 11 on each axis).
  const CommandResult run = blmd::testing::Run(
      Surface(config, trace,
              "--grid J=1.26e-5:3.26e-5:11 --grid B=1.261e-5:3.261e-5:11 --json --out " +
                  dir.File("s.csv")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto out = nlohmann::json::parse(run.out);
  EXPECT_DOUBLE_EQ(out["minimum"]["J"].get<double>(), 2.26e-5);
  EXPECT_DOUBLE_EQ(out["minimum"]["B"].get<double>(), 2.261e-5);
  EXPECT_LT(out["minimum"]["cost"].get<double>(), 1e-20);
}

// The bundled BLMD trace (testdata/blmd-d31x-step.csv, 1 V step, 1 % noise), J = 11.9e-4.
TEST(Surface, CurrentCostOverJIsSincLikeAndVelocityCostHasOneMinimum) {
  TempDir dir;
  const std::string config = SourcePath("configs/blmd-d31x.json");
  const std::string trace = SourcePath("testdata/blmd-d31x-step.csv");
  const std::string grid = "--grid J=8.33e-4:1.547e-3:61 --json --out " + dir.File("s.csv");
  const CommandResult current = blmd::testing::Run(Surface(config, trace, grid + " --observe i"));
  ASSERT_EQ(current.exit_code, 0) << current.err;
  const auto i_out = nlohmann::json::parse(current.out);
  const CommandResult velocity = blmd::testing::Run(Surface(config, trace, grid + " --observe w"));
  ASSERT_EQ(velocity.exit_code, 0) << velocity.err;
  const auto w_out = nlohmann::json::parse(velocity.out);
  std::cout << "current: " << i_out["local_minima"].size()
            << " local minima, global at J = " << i_out["minimum"]["J"]
            << "; velocity: " << w_out["local_minima"].size()
            << " local minimum at J = " << w_out["minimum"]["J"] << "\n";
  EXPECT_GE(i_out["local_minima"].size(), 3u);  // the global one and at least two others
  int below = 0, above = 0;
  for (const auto& m : i_out["local_minima"]) {
    below += m["J"].get<double>() < 1.19e-3;
    above += m["J"].get<double>() > 1.19e-3;
  }
  EXPECT_GE(below, 1);  // local minima on both sides of the global one
  EXPECT_GE(above, 1);
  EXPECT_NEAR(i_out["minimum"]["J"].get<double>(), 1.19e-3, 0.02 * 1.19e-3);
  EXPECT_EQ(w_out["local_minima"].size(), 1u);
  EXPECT_NEAR(w_out["minimum"]["J"].get<double>(), 1.19e-3, 0.02 * 1.19e-3);
}

TEST(Surface, ShardedThenMergedEqualsUnshardedAndThreadsDoNotChangeResults) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string trace = SourcePath("testdata/ganesh-noload-step.csv");
  const std::string grid = "--grid J=log:1e-5:5e-5:7 --grid B=log:1e-5:5e-5:5 --quiet";
  ASSERT_EQ(
      blmd::testing::Run(Surface(config, trace, grid + " --threads 1 --out " + dir.File("one.csv")))
          .exit_code,
      0);
  ASSERT_EQ(
      blmd::testing::Run(Surface(config, trace, grid + " --threads 2 --out " + dir.File("two.csv")))
          .exit_code,
      0);
  EXPECT_EQ(Slurp(dir.File("one.csv")), Slurp(dir.File("two.csv")));
  std::string parts;
  for (int k = 1; k <= 3; ++k) {
    const std::string part = dir.File("part" + std::to_string(k) + ".csv");
    ASSERT_EQ(
        blmd::testing::Run(
            Surface(config, trace, grid + " --shard " + std::to_string(k) + "/3 --out " + part))
            .exit_code,
        0);
    parts = part + " " + parts;  // merge must not depend on the order given
  }
  const CommandResult merge = blmd::testing::Run(BinPath("blmd-surface") + " merge " + parts +
                                                 " --out " + dir.File("merged.csv"));
  ASSERT_EQ(merge.exit_code, 0) << merge.err;
  EXPECT_EQ(Slurp(dir.File("merged.csv")), Slurp(dir.File("one.csv")));
  // 35 rows plus the header.
  const std::string merged = Slurp(dir.File("merged.csv"));
  const std::string table = merged.substr(merged.find("J,B,"));
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 36);
  // A missing shard is an error.
  const CommandResult incomplete =
      blmd::testing::Run(BinPath("blmd-surface") + " merge " + dir.File("part1.csv") + " " +
                         dir.File("part2.csv") + " --out " + dir.File("bad.csv"));
  EXPECT_EQ(incomplete.exit_code, 2);
  EXPECT_NE(incomplete.err.find("shard 3/3 is missing"), std::string::npos) << incomplete.err;
  EXPECT_FALSE(FileExists(dir.File("bad.csv")));
}

TEST(Surface, BadGridsExitTwoWithAClearMessageAndNoOutput) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string trace = SourcePath("testdata/ganesh-noload-step.csv");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--grid J=1e-5:3e-5:0", "N must be a whole number of points >= 1 (got 0)"},
      {"--grid J=3e-5:1e-5:11", "the range is inverted or empty (LO must be below HI)"},
      {"--grid Jm=1e-5:3e-5:11", "--grid: unknown parameter 'Jm' (did you mean 'J'?)"},
      {"--grid J=log:0:1e-5:5", "a log: axis needs LO > 0"},
      {"--grid J=1e-5:3e-5", "expected P=LO:HI:N or P=log:LO:HI:N"},
      {"--grid J=1e-5:3e-5:3 --shard 4/3", "--shard '4/3': expected K/N with 1 <= K <= N"},
  };
  for (const auto& [arguments, message] : cases) {
    const std::string out = dir.File("s.csv");
    const CommandResult run =
        blmd::testing::Run(Surface(config, trace, arguments + " --out " + out));
    EXPECT_EQ(run.exit_code, 2) << arguments << ": " << run.err;
    EXPECT_NE(run.err.find(message), std::string::npos) << arguments << ": " << run.err;
    EXPECT_FALSE(FileExists(out)) << arguments;
  }
}

}  // namespace
}  // namespace blmd::testing
