// The rigs' MATLAB files read directly (docs/trace-format.md, "MATLAB .mat files"): each fit
// on the .mat file against the same fit on the CSV twin that the data folder's README made
// of it (scipy.io.loadmat, numpy.savetxt: no filtering, no cut). The CSVs' printed digits are
// what separates the two (EMPS: t to 1e-8 s, the force gtau * vir to 1e-7 N, positions to
// 1e-10 m; HSM150: w to 1e-6 rad/s, t and the torque command exact), so J and B must agree
// within 1e-6 relative (measured 2026-11-28: EMPS 9e-8 at most, HSM150 3e-9). The NRMSE is
// held to 1e-5: EMPS's time stamps printed to 1e-8 s move a 1 ms step by up to 1e-5, and the
// equation error's second differences feel it (2e-6 measured; a CSV written from the .mat
// with every digit gives the .mat's numbers bit for bit). The CSVs' columns are made from
// the variables by flags:
// EMPS's F_N = gtau * vir is --column u=vir --scale u=35.15065188248547 (the stored gtau);
// HSM150's columns are those of the matrix `data` (README: t_s = col 1, w_radps = col 4,
// tau_cmd_Nm = col 5). As the other real-data tests, absent data is a skip with the reason.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string RealData() {
  const char* env = std::getenv("BLMD_REALDATA");
  return env && *env ? std::string(env) : SourcePath("../shared/realdata");
}

#define REQUIRE_REAL_DATA(folder)                                                                \
  do {                                                                                           \
    const std::string path = RealData() + "/" + (folder);                                        \
    if (!std::filesystem::is_directory(path)) GTEST_SKIP() << "real data not found at " << path; \
  } while (0)

nlohmann::json Ident(const std::string& arguments) {
  TempDir dir;
  const std::string report = dir.File("report.json");
  const CommandResult run =
      blmd::testing::Run("cd " + SourcePath("") + " && " + BinPath("blmd-ident") + " " + arguments +
                         " --threads 2 --quiet --report " + report);
  EXPECT_EQ(run.exit_code, 0) << arguments << "\n" << run.err;
  if (run.exit_code != 0) return nlohmann::json::object();
  return nlohmann::json::parse(Slurp(report));
}

// J and B of the two reports within `tolerance` relative; the numbers are printed.
void ExpectSameFit(const std::string& what, const nlohmann::json& csv, const nlohmann::json& mat,
                   double tolerance) {
  ASSERT_TRUE(csv.contains("parameters"));
  ASSERT_TRUE(mat.contains("parameters"));
  for (const char* name : {"J", "B"}) {
    const double a = csv["parameters"][name]["value"].get<double>();
    const double b = mat["parameters"][name]["value"].get<double>();
    std::cout << std::setprecision(12) << what << " " << name << ": csv " << a << ", mat " << b
              << ", relative " << (b - a) / a << "\n";
    EXPECT_LE(std::abs(b - a), tolerance * std::abs(a)) << what << " " << name;
  }
  for (const char* part : {"fit", "validation"}) {
    if (!csv.contains(part)) continue;
    ASSERT_TRUE(mat.contains(part)) << what << " " << part;
    const double a = csv[part]["nrmse"].get<double>(), b = mat[part]["nrmse"].get<double>();
    EXPECT_LE(std::abs(b - a), 1e-5 * a) << what << " " << part << " NRMSE";
  }
}

TEST(MatRealData, EmpsMatFilesGiveTheFitOfTheirCsvTwins) {
  REQUIRE_REAL_DATA("emps");
  const std::string d = RealData() + "/emps/";
  const std::string rest = " --derive w=theta --initial-state trace";
  for (const std::string config : {"configs/real/emps.json", "configs/real/emps-idim.json"}) {
    const nlohmann::json csv =
        Ident("--config " + config + " --trace " + d + "emps_estimation.csv --validate " + d +
              "emps_validation_pulses.csv --column t=t_s --column u=F_N --column theta=q_m" + rest);
    const nlohmann::json mat = Ident(
        "--config " + config + " --trace " + d + "DATA_EMPS.mat --validate " + d +
        "DATA_EMPS_PULSES.mat --column u=vir --scale u=35.15065188248547 --column theta=qm" + rest);
    ExpectSameFit(config, csv, mat, 1e-6);
    EXPECT_TRUE(mat.contains("validation"));
    EXPECT_EQ(mat["trace"]["samples"], 24841);
  }
}

TEST(MatRealData, Hsm150MatFileGivesTheFitOfItsCsvTwin) {
  REQUIRE_REAL_DATA("hsm150");
  const std::string d = RealData() + "/hsm150/";
  // docs/real-data.md's fit of one run: J, B and a constant torque (J = 1.235e-4 there).
  const std::string config = "--config configs/real/hsm150.json --trace ";
  const std::string discovery = " --discover --candidates load_torque --max-effects 1";
  const nlohmann::json csv = Ident(config + d +
                                   "idf_pos_0.065_1.csv --column t=t_s --column u=tau_cmd_Nm "
                                   "--column w=w_radps" +
                                   discovery);
  const nlohmann::json mat = Ident(config + d +
                                   "idf_pos_0.065_1.mat --column t=data:1 --column u=data:5 "
                                   "--column w=data:4" +
                                   discovery);
  ExpectSameFit("hsm150 pos_0.065_1", csv, mat, 1e-6);
  EXPECT_NEAR(mat["parameters"]["J"]["value"].get<double>(), 1.235e-4, 0.001e-4);
  EXPECT_TRUE(mat["parameters"].contains("TL"));
  EXPECT_EQ(mat["trace"]["samples"], 20000);
}

}  // namespace
}  // namespace blmd::testing
