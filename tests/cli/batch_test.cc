// blmd-ident --batch (docs/fleet.md): one identification per manifest row, the table, the
// exit codes, error rows for bad rows, resuming, the drift rule against a baseline folder, and
// the same table on one thread and two.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/io/config.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using nlohmann::json;
using testing::BinPath;
using testing::CommandResult;
using testing::FileExists;
using testing::Run;
using testing::Slurp;
using testing::SourcePath;
using testing::TempDir;

std::vector<json> Lines(const std::string& jsonl) {
  std::vector<json> out;
  std::istringstream in(jsonl);
  std::string line;
  while (std::getline(in, line)) out.push_back(json::parse(line));
  return out;
}

// A dc_servo config with J and B set, and the square-wave trace blmd-sim makes of it with 1 %
// noise on i and w.
std::string MakeTrace(const TempDir& dir, const std::string& name, double J, double B, int seed) {
  json config = json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  config["parameters"]["J"] = J;
  config["parameters"]["B"] = B;
  const std::string config_path = dir.Write(name + "-truth.json", config.dump());
  const std::string trace = dir.File(name + ".csv");
  const CommandResult sim =
      testing::Run(BinPath("blmd-sim") + " --config " + config_path + " --out " + trace +
                   " --noise i=1% --noise w=1% --quiet --seed " + std::to_string(seed));
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  return trace;
}

std::string Batch(const std::string& manifest, const std::string& out,
                  const std::string& more = "") {
  return BinPath("blmd-ident") + " --batch " + manifest + " --out " + out + " " + more;
}

// The table without its timing column (which differs run to run).
std::string WithoutWallTime(const std::string& csv) {
  std::istringstream in(csv);
  std::string line, out;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream h(line);
  for (std::string cell; std::getline(h, cell, ',');) header.push_back(cell);
  std::size_t wall = 0;
  while (wall < header.size() && header[wall] != "wall_time_s") ++wall;
  EXPECT_LT(wall, header.size());
  out += line + "\n";
  while (std::getline(in, line)) {
    // No cell of these tables holds a quoted comma before wall_time_s's column: split plainly.
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (wall < cells.size()) cells[wall] = "";
    for (std::size_t k = 0; k < cells.size(); ++k) out += (k ? "," : "") + cells[k];
    out += "\n";
  }
  return out;
}

TEST(Batch, OneRowPerManifestRowErrorRowsAndExitCodes) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-square.json");
  const std::string a = MakeTrace(dir, "a", 2.26e-5, 2.26e-5, 1);
  const std::string b = MakeTrace(dir, "b", 2.5e-5, 2.0e-5, 2);
  dir.Write("corrupt.csv", "t,u,i,w\n0,1,2,3\n0.001,1,2,x\n");
  const std::string manifest = dir.Write("fleet.csv",
                                         "id,trace,config,baseline,drive,date,args\n"
                                         "a,a.csv," +
                                             config +
                                             ",,drive-a,2026-11-01,\n"
                                             "b,b.csv," +
                                             config +
                                             ",,drive-b,2026-11-01,--method powell\n"
                                             "ab,a.csv;b.csv," +
                                             config +
                                             ",,drive-ab,2026-11-01,\n"
                                             "broken,corrupt.csv," +
                                             config +
                                             ",,drive-c,2026-11-01,\n"
                                             "a,a.csv," +
                                             config +
                                             ",,drive-a,2026-11-02,\n"
                                             "rep,a.csv," +
                                             config +
                                             ",,drive-r,,--report x.json\n"
                                             "bad-flag,a.csv," +
                                             config + ",,drive-f,,--no-such-flag\n");
  const std::string out = dir.File("out");
  const CommandResult r = testing::Run(Batch(manifest, out, "--threads 2"));
  EXPECT_EQ(r.exit_code, 1) << r.err;  // a row failed
  EXPECT_NE(r.out.find("batch: 7 rows: 3 ok, 0 drift, 4 error (6 run, 0 unchanged"),
            std::string::npos)
      << r.out;
  const std::vector<json> lines = Lines(Slurp(out + "/results.jsonl"));
  ASSERT_EQ(lines.size(), 7u);
  EXPECT_EQ(lines[0]["status"], "ok");
  EXPECT_EQ(lines[0]["drive"], "drive-a");
  EXPECT_NEAR(lines[0]["J"].get<double>(), 2.26e-5, 2.26e-5 * 0.01);
  EXPECT_NEAR(lines[1]["J"].get<double>(), 2.5e-5, 2.5e-5 * 0.01);
  // The row's args are its flags: powell fitted b.
  EXPECT_EQ(json::parse(Slurp(out + "/b.json"))["method"], "powell");
  EXPECT_EQ(lines[2]["status"], "ok");  // two traces, one fit
  EXPECT_EQ(json::parse(Slurp(out + "/ab.json"))["traces"].size(), 2u);
  EXPECT_EQ(lines[3]["status"], "error");
  EXPECT_NE(lines[3]["message"].get<std::string>().find("corrupt.csv:3:4:"), std::string::npos)
      << lines[3]["message"];
  EXPECT_EQ(lines[4]["message"], manifest + ":6:1: id 'a' repeats line 2");
  EXPECT_NE(lines[5]["message"].get<std::string>().find("args: --report: not for a batch row"),
            std::string::npos)
      << lines[5]["message"];
  EXPECT_NE(lines[6]["message"].get<std::string>().find("--no-such-flag"), std::string::npos)
      << lines[6]["message"];
  // The CSV: a header and one line per row, the documented columns first.
  const std::string csv = Slurp(out + "/results.csv");
  EXPECT_EQ(csv.rfind("id,drive,date,status,J,J_ci95_low,J_ci95_high,B,B_ci95_low,B_ci95_high,"
                      "nrmse,drift_z,drift_threshold,moved,effects,warnings,message,",
                      0),
            0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 8);
  EXPECT_TRUE(FileExists(out + "/fleet.html"));
  EXPECT_FALSE(FileExists(out + "/broken.json"));
}

TEST(Batch, ResumesOnlyWhatChangedOrDidNotFinish) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-square.json");
  MakeTrace(dir, "a", 2.26e-5, 2.26e-5, 1);
  MakeTrace(dir, "b", 2.4e-5, 2.1e-5, 2);
  MakeTrace(dir, "c", 2.1e-5, 2.3e-5, 3);
  const std::string manifest = dir.Write("fleet.csv",
                                         "id,trace,config,baseline\n"
                                         "a,a.csv," +
                                             config +
                                             ",\n"
                                             "b,b.csv," +
                                             config +
                                             ",\n"
                                             "c,c.csv," +
                                             config + ",\n");
  const std::string out = dir.File("out");
  const CommandResult first = testing::Run(Batch(manifest, out, "--threads 1"));
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find("(3 run, 0 unchanged"), std::string::npos) << first.out;
  const std::string table = WithoutWallTime(Slurp(out + "/results.csv"));
  const CommandResult again = testing::Run(Batch(manifest, out, "--threads 1"));
  EXPECT_NE(again.out.find("(0 run, 3 unchanged"), std::string::npos) << again.out;
  // A row that did not finish (its line gone: the run was killed before it) and a row whose
  // trace changed are run again; nothing else.
  std::remove((out + "/rows/a.json").c_str());
  MakeTrace(dir, "c", 2.1e-5, 2.3e-5, 4);
  const CommandResult resumed = testing::Run(Batch(manifest, out, "--threads 1"));
  EXPECT_NE(resumed.out.find("(2 run, 1 unchanged"), std::string::npos) << resumed.out;
  // A trace that turns corrupt: the row is an error row and its earlier report is gone.
  dir.Write("b.csv", "t,u,i,w\n0,1,2,3\n0,1,2,3\n");
  const CommandResult corrupt = testing::Run(Batch(manifest, out, "--threads 1"));
  EXPECT_EQ(corrupt.exit_code, 1);
  EXPECT_NE(corrupt.out.find("(1 run, 2 unchanged"), std::string::npos) << corrupt.out;
  EXPECT_FALSE(FileExists(out + "/b.json"));
  MakeTrace(dir, "b", 2.4e-5, 2.1e-5, 2);
  // Other flags are other inputs: every row runs again.
  const CommandResult other = testing::Run(Batch(manifest, out, "--threads 1 --method powell"));
  EXPECT_NE(other.out.find("(3 run, 0 unchanged"), std::string::npos) << other.out;
  // The same table on two threads as on one (rows in the manifest's order).
  const std::string out2 = dir.File("out2");
  ASSERT_EQ(testing::Run(Batch(manifest, out2, "--threads 2")).exit_code, 0);
  const std::string out1 = dir.File("out1");
  ASSERT_EQ(testing::Run(Batch(manifest, out1, "--threads 1")).exit_code, 0);
  EXPECT_EQ(WithoutWallTime(Slurp(out1 + "/results.csv")),
            WithoutWallTime(Slurp(out2 + "/results.csv")));
  EXPECT_EQ(WithoutWallTime(Slurp(out1 + "/results.csv")),
            WithoutWallTime(Slurp(out2 + "/results.csv")));
  (void)table;
}

TEST(Batch, DriftAgainstEachDrivesOwnBaseline) {
  TempDir dir;
  const std::string config = SourcePath("configs/ganesh-square.json");
  MakeTrace(dir, "steady-1", 2.26e-5, 2.26e-5, 1);
  MakeTrace(dir, "steady-2", 2.26e-5, 2.26e-5, 2);
  MakeTrace(dir, "drifts-1", 2.4e-5, 2.1e-5, 3);
  MakeTrace(dir, "drifts-2", 2.4e-5 * 1.15, 2.1e-5, 4);  // J +15 %
  const std::string night1 = dir.Write("night1.csv",
                                       "id,trace,config,baseline,drive,date\n"
                                       "s1,steady-1.csv," +
                                           config +
                                           ",,steady,2026-11-01\n"
                                           "d1,drifts-1.csv," +
                                           config + ",,drifts,2026-11-01\n");
  const std::string night2 = dir.Write("night2.csv",
                                       "id,trace,config,baseline,drive,date\n"
                                       "s2,steady-2.csv," +
                                           config +
                                           ",,steady,2026-11-02\n"
                                           "d2,drifts-2.csv," +
                                           config + ",,drifts,2026-11-02\n");
  const std::string base = dir.File("baselines");
  const CommandResult first =
      testing::Run(Batch(night1, dir.File("out1"), "--baseline-dir " + base + " --new-baselines"));
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find("baselines stored: 2 in " + base), std::string::npos) << first.out;
  EXPECT_TRUE(FileExists(base + "/steady.json"));
  const CommandResult second =
      testing::Run(Batch(night2, dir.File("out2"), "--baseline-dir " + base));
  EXPECT_EQ(second.exit_code, 3) << second.out << second.err;  // a drive drifted
  const std::vector<json> lines = Lines(Slurp(dir.File("out2/results.jsonl")));
  ASSERT_EQ(lines.size(), 2u);
  // Two parameters compared at a false-alarm rate of 1 %: z > the normal 1 - 0.01/4 quantile.
  EXPECT_NEAR(lines[0]["drift_threshold"].get<double>(), 2.807033768, 1e-8);
  EXPECT_EQ(lines[0]["status"], "ok");
  EXPECT_LT(lines[0]["drift_z"].get<double>(), 2.807);
  EXPECT_EQ(lines[1]["status"], "drift");
  EXPECT_GT(lines[1]["drift_z"].get<double>(), 10.0);
  EXPECT_EQ(lines[1]["moved"], "J");
  EXPECT_NE(lines[1]["message"].get<std::string>().find("drifted from the baseline: J +1"),
            std::string::npos)
      << lines[1]["message"];
  EXPECT_NEAR(lines[1]["J_baseline"].get<double>(), 2.4e-5, 2.4e-5 * 0.01);
  // Each line is made from the typed report; it says what the row's JSON report says.
  for (const json& line : lines) {
    const json report = json::parse(Slurp(dir.File("out2/" + line["report"].get<std::string>())));
    for (const char* name : {"J", "B"}) {
      const json& p = report["parameters"][name];
      EXPECT_EQ(line[name], p["value"]) << name;
      EXPECT_EQ(line[std::string(name) + "_ci95_low"], p["ci95"][0]) << name;
      EXPECT_EQ(line[std::string(name) + "_ci95_high"], p["ci95"][1]) << name;
      const json& b = report["baseline"]["parameters"][name];
      EXPECT_EQ(line[std::string(name) + "_baseline"], b["baseline"]) << name;
      EXPECT_EQ(line[std::string(name) + "_baseline_ci95_low"], b["baseline_ci95"][0]) << name;
    }
    EXPECT_EQ(line["nrmse"], report["fit"]["nrmse"]);
    std::string codes;
    for (const json& w : report["warnings"])
      codes += (codes.empty() ? "" : ";") + w["code"].get<std::string>();
    EXPECT_EQ(line["warnings"], codes);
  }
  // The fleet page lists the drifted drive first.
  const std::string html = Slurp(dir.File("out2/fleet.html"));
  EXPECT_LT(html.find("data-status=\"drift\""), html.find("data-status=\"ok\""));
  EXPECT_NE(html.find("href=\"d2.json\""), std::string::npos);
}

TEST(Batch, BadManifestOrFlagsWriteNothing) {
  TempDir dir;
  const std::string out = dir.File("out");
  const std::string no_config = dir.Write("m1.csv", "id,trace\nx,a.csv\n");
  CommandResult r = testing::Run(Batch(no_config, out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "error: " + no_config +
                       ":1:1: the header has no column 'config' (a manifest's header: "
                       "id,trace,config,baseline; docs/fleet.md)\n");
  const std::string typo = dir.Write("m2.csv", "id,trace,config,baselin\n");
  r = testing::Run(Batch(typo, out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(typo + ":1:17: unknown column 'baselin'"), std::string::npos) << r.err;
  r = testing::Run(Batch(dir.File("missing.csv"), out));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.csv: cannot read"), std::string::npos) << r.err;
  const std::string ok = dir.Write("m3.csv", "id,trace,config\n");
  r = testing::Run(Batch(ok, out, "--report r.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--report: not for a batch row"), std::string::npos) << r.err;
  r = testing::Run(Batch(ok, out, "--drift-alpha 0"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--drift-alpha: must be a number in (0, 1), not 0"), std::string::npos)
      << r.err;
  r = testing::Run(BinPath("blmd-ident") + " --batch " + ok);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "error: --batch needs --out DIR (the output folder)\n");
  r = testing::Run(BinPath("blmd-ident") + " --out " + out + " --config c.json --trace t.csv");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--out requires --batch"), std::string::npos) << r.err;
  EXPECT_FALSE(FileExists(out));
}

}  // namespace
}  // namespace blmd
