// Identification from the reference (identification.simulate_from "reference", --simulate-from
// reference; docs/identification.md §9b): a closed-loop record of a rigid_load speed loop
// (blmd-sim: a digital PI at 1 kHz with one sample of delay, a square speed reference within the
// drive's limit, 1 % noise on the measured speed), fitted with the drive's controller in the
// config.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using nlohmann::json;
using testing::BinPath;
using testing::TempDir;

std::string Loop(double kp, double u_max = 50) {
  std::ostringstream text;
  text << R"({ "name": "loop", "model": "rigid_load",
    "parameters": { "J": 1e-3, "B": 0.02, "Kt": 0.5 },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "square", "amplitude": 20, "period": 0.5 },
                    "duration": 3, "sample_rate": 1000,
                    "pid": { "loop": "speed", "Kp": )"
       << kp << R"(, "Ki": 6, "u_max": )" << u_max << R"(, "sample_rate": 1000, "delay": 1 } },
    "identification": { "free": ["J", "B"], "observe": ["w"] } })";
  return text.str();
}

// The trace's t, r and w only (no command logged): J and B within 1 %, the summary's note
// saying the fit ran from the reference; a loop that reaches its limit is warned about. The
// command observed too, no controller, or no r column: refused in one line (exit 2).
TEST(ReferenceInput, FitsTheLoopFromTheReferenceWithoutTheCommand) {
  TempDir dir;
  std::string truth_text = Loop(0.3);
  truth_text.replace(truth_text.find(R"("J": 1e-3, "B": 0.02)"), 20, R"("J": 2e-3, "B": 0.04)");
  const std::string truth = dir.Write("truth.json", truth_text);
  const std::string full = dir.File("full.csv");
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth + " --out " + full +
                         " --noise w=1% --seed 3")
                .exit_code,
            0);
  // The same record without u: what a PLC logs (set-point and response).
  std::ifstream in(full);
  std::ofstream out(dir.File("logged.csv"));
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream fields(line);
    std::string t, u, w, theta, r;
    std::getline(fields, t, ',');
    std::getline(fields, u, ',');
    std::getline(fields, w, ',');
    std::getline(fields, theta, ',');
    std::getline(fields, r, ',');
    if (header) {
      ASSERT_EQ(t + u + w + theta + r, "tuwthetar");
    }
    out << t << "," << r << "," << w << "\n";
    header = false;
  }
  out.close();
  const std::string config = dir.Write("fit.json", Loop(0.3));
  const std::string report = dir.File("report.json");
  const auto run = testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                                dir.File("logged.csv") + " --simulate-from reference --report " +
                                report + " --write-config " + dir.File("refit.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // The written config refits from the reference too.
  EXPECT_EQ(json::parse(testing::Slurp(dir.File("refit.json")))["identification"]["simulate_from"],
            "reference");
  EXPECT_NE(run.out.find("note: identified from the reference"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("reference_saturated"), std::string::npos) << run.out;
  const json p = json::parse(testing::Slurp(report))["parameters"];
  // Within 1 % and within 4 standard errors (the study tests/studies/reference_input.py
  // measures the intervals' coverage over many records).
  for (const auto& [name, value] : {std::pair<const char*, double>{"J", 2e-3}, {"B", 0.04}}) {
    EXPECT_NEAR(p[name]["value"].get<double>(), value, 0.01 * value) << name;
    EXPECT_NEAR(p[name]["value"].get<double>(), value, 4.0 * p[name]["std"].get<double>()) << name;
  }
  // The command observed too (the joint approach) is refused, naming the direct fit.
  const auto joint = testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                                  full + " --simulate-from reference --observe w,u");
  EXPECT_EQ(joint.exit_code, 2) << joint.err;
  EXPECT_NE(joint.err.find("fit from the logged command with --simulate-from command"),
            std::string::npos)
      << joint.err;
  // The same loop with a limit of 5 N·m, which the steps reach: the warning says the fit from
  // the reference is biased there and names the fix.
  const std::string limited_truth = dir.Write("limited-truth.json", [&] {
    std::string text = Loop(0.3, 5);
    text.replace(text.find(R"("J": 1e-3, "B": 0.02)"), 20, R"("J": 2e-3, "B": 0.04)");
    return text;
  }());
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + limited_truth + " --out " +
                         dir.File("limited.csv") + " --noise w=1% --seed 3")
                .exit_code,
            0);
  const auto limited =
      testing::Run(BinPath("blmd-ident") + " --config " + dir.Write("limited.json", Loop(0.3, 5)) +
                   " --trace " + dir.File("limited.csv") + " --simulate-from reference");
  ASSERT_EQ(limited.exit_code, 0) << limited.err;
  EXPECT_NE(limited.out.find("warning [reference_saturated]: the drive's loop sits on its limit"),
            std::string::npos)
      << limited.out;
  EXPECT_NE(limited.out.find("fit from the logged command (--simulate-from command)"),
            std::string::npos)
      << limited.out;
  // No controller: refused.
  std::string open_text = Loop(0.3);
  const auto pid = open_text.find(R"(,
                    "pid")");
  ASSERT_NE(pid, std::string::npos);
  open_text.erase(pid, open_text.find('}', pid) + 1 - pid);
  const std::string open = dir.Write("open.json", open_text);
  const auto no_pid = testing::Run(BinPath("blmd-ident") + " --config " + open + " --trace " +
                                   dir.File("logged.csv") + " --simulate-from reference");
  EXPECT_EQ(no_pid.exit_code, 2) << no_pid.err;
  EXPECT_NE(no_pid.err.find("the config needs its controller (experiment.pid)"), std::string::npos)
      << no_pid.err;
  // No reference column: refused naming it.
  std::ofstream no_r(dir.File("no-r.csv"));
  no_r << "t,u,w\n0,0,0\n0.001,0,0\n0.002,0,0\n0.003,0,0\n";
  no_r.close();
  const auto missing = testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                                    dir.File("no-r.csv") + " --simulate-from reference");
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  EXPECT_NE(missing.err.find("missing required column 'r'"), std::string::npos) << missing.err;
}

// --closed-loop is --simulate-from reference by its name (the two at once: exit 2); on
// dc_servo the config's PID is the drive's digital controller (1 kHz, one sample late), and a
// record of its reference and response alone (t, r, w, theta) gives J and B within 1 % and 4
// standard errors.
TEST(ReferenceInput, ClosedLoopFlagAndTheDcServosDigitalPid) {
  TempDir dir;
  json truth = json::parse(testing::Slurp(testing::SourcePath("configs/ganesh-pid.json")));
  truth["experiment"]["pid"]["sample_rate"] = 1000;
  truth["experiment"]["pid"]["delay"] = 1;
  truth["experiment"]["input"] = {{"type", "square"}, {"amplitude", 1.0}, {"period", 0.5}};
  truth["experiment"]["duration"] = 2.0;
  truth["identification"]["observe"] = {"w", "theta"};
  const std::string truth_path = dir.Write("truth.json", truth.dump(2));
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth_path + " --out " +
                         dir.File("full.csv") + " --noise w=0.5% --noise theta=0.2% --seed 5")
                .exit_code,
            0);
  std::ifstream in(dir.File("full.csv"));
  std::ofstream out(dir.File("logged.csv"));
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream fields(line);
    std::string t, u, i, w, theta, r;
    for (std::string* field : {&t, &u, &i, &w, &theta, &r}) std::getline(fields, *field, ',');
    if (header) {
      ASSERT_EQ(t + u + i + w + theta + r, "tuiwthetar");
    }
    out << t << "," << r << "," << w << "," << theta << "\n";
    header = false;
  }
  out.close();
  json start = truth;  // the fit starts 30 % off
  start["parameters"]["J"] = 1.3 * 2.26e-5;
  start["parameters"]["B"] = 0.7 * 2.261e-5;
  const std::string config = dir.Write("fit.json", start.dump(2));
  const std::string fit = BinPath("blmd-ident") + " --config " + config + " --trace " +
                          dir.File("logged.csv") + " --quiet";
  const auto named = testing::Run(fit + " --closed-loop --report " + dir.File("a.json"));
  ASSERT_EQ(named.exit_code, 0) << named.err;
  const auto spelled =
      testing::Run(fit + " --simulate-from reference --report " + dir.File("b.json"));
  ASSERT_EQ(spelled.exit_code, 0) << spelled.err;
  const json a = json::parse(testing::Slurp(dir.File("a.json")))["parameters"];
  const json b = json::parse(testing::Slurp(dir.File("b.json")))["parameters"];
  for (const auto& [name, value] :
       {std::pair<const char*, double>{"J", 2.26e-5}, {"B", 2.261e-5}}) {
    EXPECT_EQ(a[name]["value"], b[name]["value"]) << name;
    EXPECT_NEAR(a[name]["value"].get<double>(), value, 0.01 * value) << name;
    EXPECT_NEAR(a[name]["value"].get<double>(), value, 4.0 * a[name]["std"].get<double>()) << name;
  }
  const auto both = testing::Run(fit + " --closed-loop --simulate-from command");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--simulate-from excludes --closed-loop"), std::string::npos) << both.err;
}

// A PD position loop with a speed reference, u = Kp' (r - theta) + Kd' (r' - w) (a lab rig's
// controller): written as the cascade with speed_feedforward 1 and no speed integral. The
// command is what the PD computes from the sampled r, theta and w (checked on the simulated
// trace), and the record fits from t, r, w and theta alone: J and B within 1 % and 4 standard
// errors.
TEST(ReferenceInput, PdWithASpeedReference) {
  TempDir dir;
  const double kp_pd = 4.0, kd_pd = 0.08;  // N·m/rad, N·m·s/rad
  json truth = {{"name", "pd"},
                {"model", "rigid_load"},
                {"parameters", {{"J", 2e-3}, {"B", 0.04}, {"Kt", 1.0}}},
                {"simulation", {{"dt", 1e-4}}},
                {"experiment",
                 {{"input", {{"type", "chirp"}, {"amplitude", 3.0}, {"f0", 0.3}, {"f1", 8.0}}},
                  {"duration", 4.0},
                  {"sample_rate", 1000},
                  {"pid",
                   {{"loop", "position"},
                    {"Kp", kp_pd / kd_pd},
                    {"speed_Kp", kd_pd},
                    {"speed_feedforward", 1.0},
                    {"u_max", 50},
                    {"sample_rate", 1000},
                    {"delay", 0}}}}},
                {"identification", {{"free", {"J", "B"}}, {"observe", {"w", "theta"}}}}};
  const std::string truth_path = dir.Write("truth.json", truth.dump(2));
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + truth_path + " --out " +
                         dir.File("clean.csv") + " --quiet")
                .exit_code,
            0);
  const Trace clean = ReadTraceCsv(dir.File("clean.csv"));
  const auto& r = clean.Column("r");
  const auto& theta = clean.Column("theta");
  const auto& w = clean.Column("w");
  const auto& u = clean.Column("u");
  double worst = 0.0;
  for (std::size_t k = 1; k < clean.rows(); ++k) {
    const double pd = kp_pd * (r[k] - theta[k]) + kd_pd * ((r[k] - r[k - 1]) / 1e-3 - w[k]);
    worst = std::max(worst, std::abs(u[k] - pd));
  }
  EXPECT_LT(worst, 1e-9);
  ASSERT_EQ(
      testing::Run(BinPath("blmd-sim") + " --config " + truth_path + " --out " +
                   dir.File("full.csv") + " --noise w=0.5% --noise theta=0.1% --seed 9 --quiet")
          .exit_code,
      0);
  const Trace full = ReadTraceCsv(dir.File("full.csv"));
  std::ostringstream logged;
  logged.precision(17);
  logged << "t,r,w,theta\n";
  for (std::size_t k = 0; k < full.rows(); ++k) {
    logged << full.Column("t")[k] << ',' << full.Column("r")[k] << ',' << full.Column("w")[k] << ','
           << full.Column("theta")[k] << '\n';
  }
  json start = truth;
  start["parameters"]["J"] = 3e-3;
  start["parameters"]["B"] = 0.02;
  const auto run =
      testing::Run(BinPath("blmd-ident") + " --config " + dir.Write("fit.json", start.dump(2)) +
                   " --trace " + dir.Write("logged.csv", logged.str()) +
                   " --closed-loop --report " + dir.File("report.json") + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json p = json::parse(testing::Slurp(dir.File("report.json")))["parameters"];
  for (const auto& [name, value] : {std::pair<const char*, double>{"J", 2e-3}, {"B", 0.04}}) {
    EXPECT_NEAR(p[name]["value"].get<double>(), value, 0.01 * value) << name;
    EXPECT_NEAR(p[name]["value"].get<double>(), value, 4.0 * p[name]["std"].get<double>()) << name;
  }
}

}  // namespace
}  // namespace blmd
