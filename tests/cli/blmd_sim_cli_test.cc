// blmd-sim as a user runs it (interface.md): the real binary, its exit codes, its files and
// its one-line errors. Bad input exits 2 with one line "error: ..." on stderr and writes
// nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/io/csv.h"
#include "blmd/version.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::BinPath;
using testing::CommandResult;
using testing::FileExists;
using testing::Run;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

std::size_t FilesIn(const std::string& folder) {
  return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(folder),
                                                std::filesystem::directory_iterator()));
}

CommandResult Sim(const std::string& arguments) {
  return Run(BinPath("blmd-sim") + " " + arguments);
}

// Ganesh's no-load motor run long enough (3 s) to reach its steady state.
constexpr const char* kSteadyConfig = R"({
  "name": "steady",
  "model": "dc_servo",
  "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
  "experiment": { "input": { "type": "step", "amplitude": 24.0 }, "duration": 3.0, "sample_rate": 100 }
})";

// Exit 2, exactly one line on stderr starting "error: ", nothing on stdout, no file written.
void ExpectBadInput(const CommandResult& result, const std::string& out_path,
                    const std::string& expected_line) {
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_EQ(result.err, expected_line + "\n");
  EXPECT_EQ(result.out, "");
  EXPECT_FALSE(FileExists(out_path));
}

TEST(BlmdSimCli, GoodRunWritesTheTrace) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string out = dir.File("trace.csv");
  const CommandResult result = Sim("--config " + config + " --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_EQ(result.out.substr(0, result.out.find('\n')),
            "blmd-sim: dc_servo 'ganesh-noload', 10001 samples over 1 s -> " + out);
  const std::string text = Slurp(out);
  EXPECT_EQ(text.substr(0, text.find("\n0,") + 1), "# blmd-sim " + std::string(kVersion) +
                                                       " model=dc_servo config=" + config +
                                                       "\nt,u,i,w,theta\n");
  const Trace trace = ReadTraceCsv(out);
  EXPECT_EQ(trace.rows(), 10001u);
  EXPECT_EQ(trace.Column("t").back(), 1.0);
  EXPECT_EQ(trace.Column("u").front(), 24.0);
  EXPECT_EQ(FilesIn(dir.path()), 1u);  // no temporary left behind
}

TEST(BlmdSimCli, NoiseIsReproducibleFromTheSeed) {
  TempDir dir;
  const std::string config = dir.Write("steady.json", kSteadyConfig);
  const std::string base = "--quiet --config " + config + " --out ";
  ASSERT_EQ(Sim(base + dir.File("clean.csv")).exit_code, 0);
  ASSERT_EQ(Sim(base + dir.File("a.csv") + " --noise w=0.5 --seed 7").exit_code, 0);
  ASSERT_EQ(Sim(base + dir.File("b.csv") + " --noise w=0.5 --seed 7").exit_code, 0);
  ASSERT_EQ(Sim(base + dir.File("c.csv") + " --noise w=0.5 --seed 8").exit_code, 0);
  EXPECT_EQ(Slurp(dir.File("a.csv")), Slurp(dir.File("b.csv")));
  EXPECT_NE(Slurp(dir.File("a.csv")), Slurp(dir.File("c.csv")));
  const Trace clean = ReadTraceCsv(dir.File("clean.csv"));
  const Trace noisy = ReadTraceCsv(dir.File("a.csv"));
  EXPECT_EQ(noisy.comments.back(), "noise w sigma=0.5 seed=7");
  // Only w is touched; its deviation from the clean trace has the requested sigma
  // (301 samples: the sample deviation is within 0.5 (1 +- 4/sqrt(2 * 301)) nearly always).
  EXPECT_EQ(noisy.Column("i"), clean.Column("i"));
  double sum = 0.0, sum2 = 0.0;
  const std::size_t n = clean.rows();
  for (std::size_t k = 0; k < n; ++k) {
    const double d = noisy.Column("w")[k] - clean.Column("w")[k];
    sum += d;
    sum2 += d * d;
  }
  const double sigma = std::sqrt((sum2 - sum * sum / n) / (n - 1));
  EXPECT_NEAR(sigma, 0.5, 0.5 * 4.0 / std::sqrt(2.0 * n));
  std::printf("[measured] --noise w=0.5: sample sigma %.4f over %zu samples\n", sigma, n);
}

// --effect load_torque:TL=0.005 lowers the steady speed from Kt u / (R B + Kt Kb) to
// (Kt u - R TL) / (R B + Kt Kb).
TEST(BlmdSimCli, EffectFlagAddsTheEffect) {
  TempDir dir;
  const std::string config = dir.Write("steady.json", kSteadyConfig);
  const std::string base = "--quiet --config " + config + " --out ";
  ASSERT_EQ(Sim(base + dir.File("plain.csv")).exit_code, 0);
  const CommandResult result = Sim(base + dir.File("load.csv") + " --effect load_torque:TL=0.005");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "");  // --quiet
  const double a0 = 12.6 * 2.261e-5 + 0.04 * 0.04;
  const Trace plain = ReadTraceCsv(dir.File("plain.csv"));
  const Trace load = ReadTraceCsv(dir.File("load.csv"));
  EXPECT_NEAR(plain.Column("w").back() / (0.04 * 24.0 / a0), 1.0, 1e-6);
  EXPECT_NEAR(load.Column("w").back() / ((0.04 * 24.0 - 12.6 * 0.005) / a0), 1.0, 1e-6);
  EXPECT_EQ(load.comments.back(), "effect load_torque");
  // Two effects at once; coulomb_friction with Tc = TL gives the same steady speed as the
  // load torque (both subtract a constant torque while w > 0).
  ASSERT_EQ(Sim(base + dir.File("both.csv") +
                " --effect coulomb_friction:Tc=0.005 --effect current_offset:i0=0.25")
                .exit_code,
            0);
  const Trace both = ReadTraceCsv(dir.File("both.csv"));
  EXPECT_NEAR(both.Column("w").back() / load.Column("w").back(), 1.0, 1e-9);
  EXPECT_NEAR(both.Column("i").back() - load.Column("i").back(), 0.25, 1e-9);
}

TEST(BlmdSimCli, InputFlagDrivesTheModelWithARecordedTrace) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-noload.json");
  const std::string input =
      dir.Write("drive.csv", "t,u,open\n0,0,0\n0.01,24,0\n0.2,24,0\n0.3,0,1\n0.35,0,1\n0.5,0,1\n");
  const std::string out = dir.File("out.csv");
  const CommandResult result =
      Sim("--quiet --config " + config + " --input " + input + " --out " + out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const Trace trace = ReadTraceCsv(out);
  // Read at the recorded instants; u as recorded; i = 0 once the armature is open.
  EXPECT_EQ(trace.Column("t"), (std::vector<double>{0, 0.01, 0.2, 0.3, 0.35, 0.5}));
  EXPECT_EQ(trace.Column("u"), (std::vector<double>{0, 24, 24, 0, 0, 0}));
  EXPECT_EQ(trace.Column("i")[0], 0.0);
  EXPECT_GT(trace.Column("i")[2], 0.0);
  EXPECT_EQ(trace.Column("i")[4], 0.0);
  EXPECT_EQ(trace.Column("i")[5], 0.0);
  // Coasting from t = 0.3 s: w(0.5) = w(0.3) exp(-B 0.2 / J).
  EXPECT_NEAR(trace.Column("w")[5] / (trace.Column("w")[3] * std::exp(-2.261e-5 * 0.2 / 2.26e-5)),
              1.0, 1e-9);
}

TEST(BlmdSimCli, BadInputExitsTwoWithOneLineAndWritesNothing) {
  TempDir dir;
  const std::string good = SourcePath("configs/ganesh-noload.json");
  const std::string out = dir.File("out.csv");
  const std::string bad =
      dir.Write("bad.json", "{\n  \"model\": \"dc_servo\",\n  \"paramters\": {}\n}\n");
  ExpectBadInput(
      Sim("--config " + bad + " --out " + out), out,
      "error: " + bad +
          ":3:3: unknown key 'paramters' in '(top level)' (did you mean "
          "'parameters'?); valid keys: name, description, notes, model, axis, parameters, "
          "effects, simulation, experiment, identification");
  ExpectBadInput(Sim("--config " + dir.File("missing.json") + " --out " + out), out,
                 "error: " + dir.File("missing.json") + ": cannot read: No such file or directory");
  ExpectBadInput(
      Sim("--config " + good + " --out " + out + " --effect friction:Tc=0.01"), out,
      "error: unknown effect 'friction' (valid: asymmetric_viscous, cogging, coulomb_friction, "
      "current_offset, dead_time, gravity, load_torque, quadratic_drag, spring, stribeck, "
      "two_mass)");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --effect coulomb_friction:Tc=abc"),
                 out, "error: --effect coulomb_friction Tc: 'abc' is not a finite number");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --effect coulomb_friction:tc=0.01"),
                 out,
                 "error: effect 'coulomb_friction' has no parameter 'tc' (did you mean 'Tc'?); "
                 "valid: Tc");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --effect stribeck:Ts=0.01"), out,
                 "error: effect 'stribeck' needs parameter 'ws' (Stribeck velocity, rad/s)");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --noise q=0.1"), out,
                 "error: --noise: no output column 'q' (have: t,u,i,w,theta)");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --noise w=-1"), out,
                 "error: --noise w: sigma must be >= 0");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --noise w"), out,
                 "error: --noise 'w': expected NAME=VALUE");
  ExpectBadInput(Sim("--config " + good + " --out " + out + " --input " + dir.File("none.csv")),
                 out,
                 "error: " + dir.File("none.csv") + ": cannot read: No such file or directory");
  ExpectBadInput(Sim("--config " + good + " --out /nonexistent-folder/out.csv"),
                 "/nonexistent-folder/out.csv",
                 "error: /nonexistent-folder/out.csv: cannot write in folder "
                 "'/nonexistent-folder': No such file or directory");
  // Only the files this test wrote itself are there: no output, no temporary.
  EXPECT_EQ(FilesIn(dir.path()), 1u);
}

TEST(BlmdSimCli, BadFlagsExitTwoWithOneLine) {
  TempDir dir;
  const std::string good = SourcePath("configs/ganesh-noload.json");
  const std::string out = dir.File("out.csv");
  for (const std::string& arguments :
       {"--config " + good + " --out " + out + " --bogus", "--out " + out,
        "--config " + good + " --out " + out + " --seed minus-one"}) {
    SCOPED_TRACE(arguments);
    const CommandResult result = Sim(arguments);
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_EQ(result.err.rfind("error: ", 0), 0u) << result.err;
    EXPECT_EQ(result.err.find('\n'), result.err.size() - 1) << result.err;  // one line
    // The hint names the command as it was invoked (argv[0]).
    EXPECT_NE(result.err.find("(see " + BinPath("blmd-sim") + " --help)"), std::string::npos)
        << result.err;
    EXPECT_FALSE(FileExists(out));
  }
  EXPECT_EQ(Sim("--config " + good + " --out " + out + " --bogus").err,
            "error: The following argument was not expected: --bogus (see " + BinPath("blmd-sim") +
                " --help)\n");
  EXPECT_EQ(Sim("--out " + out).err,
            "error: --config is required (see " + BinPath("blmd-sim") + " --help)\n");
}

TEST(BlmdSimCli, HelpAndVersion) {
  const CommandResult help = Sim("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_EQ(help.err, "");
  for (const char* flag :
       {"--config", "--out", "--effect", "--noise", "--seed", "--input", "--quiet", "--version"}) {
    EXPECT_NE(help.out.find(flag), std::string::npos) << flag;
  }
  const CommandResult version = Sim("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out, "blmd-sim " + std::string(kVersion) + "\n");
  EXPECT_EQ(version.err, "");
}

}  // namespace
}  // namespace blmd
