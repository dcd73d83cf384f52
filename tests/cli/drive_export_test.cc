// From an identified model into the drive (docs/export.md §6-7): blmd-export's C99 files
// compiled by the system's C compiler (double and float, strict warnings) and evaluated
// against the library's feed-forward; its ODrive and MuJoCo forms; blmd-track on records with
// and without a change of J, and the generated C tracker against blmd-track sample for sample.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/constants.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/stored_report.h"
#include "support/test_support.h"
#include "tune/compensation.h"

namespace blmd {
namespace {

using nlohmann::json;
using testing::BinPath;
using testing::TempDir;

// A rigid shaft with Coulomb friction, cogging and a spring, J and B and the effects fitted
// on a square-wave record; J of `J` kg·m² and the run starting from `initial` (w, theta).
std::string Drive(double J, double w0 = 0.0, double theta0 = 0.0) {
  std::ostringstream text;
  text.precision(17);
  text << R"({ "name": "drive", "model": "rigid_load",
    "parameters": { "J": )"
       << J << R"(, "B": 0.02, "Kt": 0.5 },
    "effects": { "coulomb_friction": { "Tc": 0.05 } },
    "simulation": { "dt": 1e-4 },
    "experiment": { "input": { "type": "square", "amplitude": 1.0, "period": 0.5 },
                    "duration": 4, "sample_rate": 1000,
                    "initial": { "w": )"
       << w0 << R"(, "theta": )" << theta0 << R"( } },
    "identification": { "free": ["J", "B", "Tc"], "observe": ["w"] } })";
  return text.str();
}

// Simulates `config` with 0.5 % speed noise into `csv`; returns its last w and theta.
std::pair<double, double> Simulate(const std::string& config, const std::string& csv, int seed) {
  const auto run = testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " + csv +
                                " --noise w=0.5% --quiet --seed " + std::to_string(seed));
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const Trace trace = ReadTraceCsv(csv);
  return {trace.Column("w").back(), trace.Column("theta").back()};
}

// The drive simulated and fitted; `terms`: with a cogging torque and a spring in the config
// too (their values the config's, not fitted), so that every term of the feed-forward is
// exercised.
struct Fitted {
  TempDir dir;
  std::string config, record, report;
  explicit Fitted(bool terms = false) {
    json drive = json::parse(Drive(1e-3));
    if (terms) {
      drive["effects"]["cogging"] = {{"Tcog", 0.03}, {"periods", 6}, {"phase", 0.4}};
      drive["effects"]["spring"] = {{"K", 0.01}, {"theta0", 0.2}};
    }
    config = dir.Write("drive.json", drive.dump(2));
    record = dir.File("drive.csv");
    Simulate(config, record, 1);
    report = dir.File("fit.json");
    const auto run = testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                                  record + " --report " + report + " --quiet");
    EXPECT_EQ(run.exit_code, 0) << run.err;
  }
};

std::vector<std::vector<double>> ReadRows(const std::string& text) {
  std::vector<std::vector<double>> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || !(std::isdigit(line[0]) || line[0] == '-')) continue;
    std::vector<double> row;
    std::stringstream fields(line);
    std::string field;
    while (std::getline(fields, field, ',')) row.push_back(std::stod(field));
    rows.push_back(row);
  }
  return rows;
}

// The C files compile alone for double and float with -std=c99 -Wall -Wextra -pedantic
// -Wconversion -Werror; blmd_ff_torque equals the library's Compensation::Torque to 1e-12
// (double) over a grid of angles, speeds and accelerations with the cogging's table within
// its interpolation bound; float within 1e-5 of the torque's scale.
TEST(DriveExport, CompensationCompilesAndMatchesTheLibrary) {
  Fitted fit(/*terms=*/true);
  const std::string with_terms = fit.config;
  const std::string out = fit.dir.File("c");
  auto run = testing::Run(BinPath("blmd-export") + " --config " + with_terms + " --from-report " +
                          fit.report + " --format c --cogging-points 720 --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string driver = fit.dir.Write("driver.c", R"(#include <stdio.h>
#include "blmd_compensation.h"
int main(void) {
  int i, j, k;
  for (i = 0; i < 9; ++i)
    for (j = 0; j < 7; ++j)
      for (k = 0; k < 3; ++k) {
        double theta = -3.0 + 0.77 * i, w = -30.0 + 10.0 * j, a = -500.0 + 500.0 * k;
        printf("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", theta, w, a,
               (double)blmd_ff_torque((blmd_real)theta, (blmd_real)w, (blmd_real)a),
               (double)blmd_ff_cogging((blmd_real)theta),
               (double)blmd_ff_cogging_harmonic((blmd_real)theta));
      }
  return 0;
})");
  const Compensation model = Compensation::FromReport(
      LoadConfig(with_terms), StoredReport::Load(fit.report, "identification report"));
  EXPECT_EQ(model.Value("Tcog"), 0.03);
  for (const std::string real : {"double", "float"}) {
    const std::string binary = fit.dir.File("ff_" + real);
    run = testing::Run(
        "cc -std=c99 -Wall -Wextra -pedantic -Wconversion -Werror -DBLMD_REAL=" + real + " -I" +
        out + " " + out + "/blmd_compensation.c " + driver + " -lm -o " + binary);
    ASSERT_EQ(run.exit_code, 0) << real << ": " << run.err;
    run = testing::Run(binary);
    ASSERT_EQ(run.exit_code, 0);
    const auto rows = ReadRows(run.out);
    ASSERT_EQ(rows.size(), 9u * 7u * 3u);
    // Linear interpolation of Tcog sin(6 theta + phase) on 720 points: at most
    // Tcog (6 * 2 pi / 720)^2 / 8.
    const double table_bound = 0.03 * std::pow(6.0 * 2.0 * kPi / 720.0, 2) / 8.0;
    const double tolerance = real == "double" ? 1e-12 : 1e-5;
    for (const auto& row : rows) {
      const double theta = row[0], w = row[1], a = row[2];
      const double harmonic = model.Cogging(theta);
      EXPECT_NEAR(row[5], harmonic, tolerance * 0.03) << real << " theta " << theta;
      EXPECT_NEAR(row[4], harmonic, table_bound * 1.01 + tolerance * 0.03) << real;
      const double expected = model.Torque(theta, w, a) - harmonic + row[4];
      EXPECT_NEAR(row[3], expected, tolerance * (1.0 + std::abs(expected)))
          << real << " theta " << theta << " w " << w << " a " << a;
    }
  }
  // Every constant carries its interval or says it is not fitted.
  const std::string header = testing::Slurp(out + "/blmd_compensation.h");
  EXPECT_NE(header.find("#define BLMD_J ((blmd_real)"), std::string::npos);
  EXPECT_NE(header.find("inertia (a mass in kg for a linear axis); 95 %: ["), std::string::npos)
      << header;
  EXPECT_NE(header.find("cogging torque amplitude; fixed (the config's value, not identified)"),
            std::string::npos);
  EXPECT_NE(header.find("Coulomb friction torque; 95 %: ["), std::string::npos);
}

// ODrive: inertia 2 pi J in N·m/(turn/s²) with its interval, 3600 map entries of the cogging
// torque per turn; MuJoCo: armature J, damping B, frictionloss Tc.
TEST(DriveExport, ODriveAndMujocoForms) {
  Fitted fit(/*terms=*/true);
  const std::string with_cogging = fit.config;
  auto run = testing::Run(BinPath("blmd-export") + " --config " + with_cogging + " --from-report " +
                          fit.report + " --format odrive --out " + fit.dir.File("odrive.json") +
                          " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json report = json::parse(testing::Slurp(fit.report));
  const double J = report["parameters"]["J"]["value"].get<double>();
  const json odrive = json::parse(testing::Slurp(fit.dir.File("odrive.json")));
  EXPECT_EQ(odrive["inertia"]["setting"], "axis0.controller.config.inertia");
  EXPECT_NEAR(odrive["inertia"]["value"].get<double>(), 2.0 * kPi * J, 1e-15);
  EXPECT_NEAR(odrive["inertia"]["ci95"][0].get<double>(),
              2.0 * kPi * report["parameters"]["J"]["ci95"][0].get<double>(), 1e-15);
  ASSERT_EQ(odrive["anticogging"]["map"].size(), 3600u);
  for (int k : {0, 1, 900, 3599}) {
    EXPECT_NEAR(odrive["anticogging"]["map"][k].get<double>(),
                0.03 * std::sin(6.0 * 2.0 * kPi * k / 3600.0 + 0.4), 1e-15)
        << k;
  }
  EXPECT_NEAR(odrive["host_feed_forward"]["terms"]["Tc"].get<double>(),
              report["parameters"]["Tc"]["value"].get<double>(), 1e-15);
  run =
      testing::Run(BinPath("blmd-export") + " --config " + fit.config + " --from-report " +
                   fit.report + " --format mujoco --out " + fit.dir.File("shaft.xml") + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string xml = testing::Slurp(fit.dir.File("shaft.xml"));
  const auto attribute = [&](const std::string& name) {
    const std::size_t at = xml.find(" " + name + "=\"");
    EXPECT_NE(at, std::string::npos) << name;
    const std::size_t start = at + name.size() + 3;
    return std::stod(xml.substr(start, xml.find('"', start) - start));
  };
  EXPECT_EQ(attribute("armature"), J);
  EXPECT_EQ(attribute("damping"), report["parameters"]["B"]["value"].get<double>());
  EXPECT_EQ(attribute("frictionloss"), report["parameters"]["Tc"]["value"].get<double>());
}

// blmd-track on the fitted record stays unchanged and covers the truth at the end; on a
// record whose J steps from 1e-3 to 1.3e-3 at t = 4 s (the second part continuing from the
// first's state) it flags the change after 4 s and ends within 2 % of 1.3e-3 (memory 1 s).
// The generated C tracker, fed the same samples, gives blmd-track's J to 1e-12.
TEST(DriveExport, TrackerFlagsAChangeOfJAndTheCTrackerAgrees) {
  Fitted fit;
  auto run = testing::Run(BinPath("blmd-track") + " --config " + fit.config + " --from-report " +
                          fit.report + " --trace " + fit.record + " --out " +
                          fit.dir.File("same.csv") + " --report " + fit.dir.File("same.json") +
                          " --html " + fit.dir.File("same.html") + " --memory 1 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string page = testing::Slurp(fit.dir.File("same.html"));
  EXPECT_NE(page.find("<svg"), std::string::npos);
  EXPECT_NE(page.find("offline 95 % interval"), std::string::npos);
  const auto same = ReadRows(testing::Slurp(fit.dir.File("same.csv")));
  ASSERT_EQ(same.size(), 4001u);
  int changed = 0;
  for (const auto& row : same) changed += static_cast<int>(row[4]);
  EXPECT_EQ(changed, 0);
  EXPECT_LE(same.back()[2], 1e-3);
  EXPECT_GE(same.back()[3], 1e-3);
  // J steps up by 30 % at t = 4 s.
  const Trace first = ReadTraceCsv(fit.record);
  const std::string later = fit.dir.Write(
      "later.json", Drive(1.3e-3, first.Column("w").back(), first.Column("theta").back()));
  Simulate(later, fit.dir.File("later.csv"), 2);
  const Trace second = ReadTraceCsv(fit.dir.File("later.csv"));
  std::ostringstream joined;
  joined.precision(17);
  joined << "t,u,w,theta\n";
  for (const Trace* part : {&first, &second}) {
    const double shift = part == &first ? 0.0 : 4.0;
    for (std::size_t k = part == &first ? 0 : 1; k < part->rows(); ++k) {
      joined << part->Column("t")[k] + shift << ',' << part->Column("u")[k] << ','
             << part->Column("w")[k] << ',' << part->Column("theta")[k] << '\n';
    }
  }
  const std::string step = fit.dir.Write("step.csv", joined.str());
  run = testing::Run(BinPath("blmd-track") + " --config " + fit.config + " --from-report " +
                     fit.report + " --trace " + step + " --out " + fit.dir.File("step-track.csv") +
                     " --report " + fit.dir.File("step.json") + " --memory 1 --fail-on-change");
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_NE(run.out.find("changed: J left its offline interval"), std::string::npos) << run.out;
  const json summary = json::parse(testing::Slurp(fit.dir.File("step.json")));
  EXPECT_TRUE(summary["changed"].get<bool>());
  EXPECT_GT(summary["first_change_t"].get<double>(), 4.0);
  EXPECT_LT(summary["first_change_t"].get<double>(), 5.0);
  EXPECT_NEAR(summary["final"]["J"].get<double>(), 1.3e-3, 0.02 * 1.3e-3);
  // The C tracker: exported for the record's 1 kHz, the same samples on its stdin.
  const std::string out = fit.dir.File("c");
  run = testing::Run(BinPath("blmd-export") + " --config " + fit.config + " --from-report " +
                     fit.report + " --format c --tracker-rate 1000 --memory 1 --out " + out +
                     " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string driver = fit.dir.Write("track.c", R"(#include <stdio.h>
#include "blmd_tracker.h"
int main(void) {
  blmd_tracker t;
  double time, u, w, theta;
  char header[64];
  if (scanf("%63s", header) != 1) return 1;
  blmd_tracker_init(&t);
  while (scanf("%lf,%lf,%lf,%lf", &time, &u, &w, &theta) == 4) {
    blmd_tracker_update(&t, (blmd_real)(0.5 * u), (blmd_real)w, (blmd_real)theta);
    printf("%.17g,%.17g,%.17g,%.17g,%d\n", time, (double)t.J, (double)t.J_low,
           (double)t.J_high, t.changed);
  }
  return 0;
})");
  run = testing::Run("cc -std=c99 -Wall -Wextra -pedantic -Werror -I" + out + " " + out +
                     "/blmd_compensation.c " + out + "/blmd_tracker.c " + driver + " -lm -o " +
                     fit.dir.File("track"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = testing::Run(fit.dir.File("track") + " < " + step);
  ASSERT_EQ(run.exit_code, 0);
  const auto c_rows = ReadRows(run.out);
  const auto cpp_rows = ReadRows(testing::Slurp(fit.dir.File("step-track.csv")));
  ASSERT_EQ(c_rows.size(), cpp_rows.size());
  double worst = 0.0;
  int flags_differ = 0;
  for (std::size_t k = 0; k < c_rows.size(); ++k) {
    worst = std::max(worst, std::abs(c_rows[k][1] - cpp_rows[k][1]) / cpp_rows[k][1]);
    flags_differ += c_rows[k][4] != cpp_rows[k][4];
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(flags_differ, 0);
}

// Refused in one line, exit 2, nothing written: a two-mass final model (its feed-forward needs
// the load's trajectory), a model without a torque constant for the tracker, the tracker
// without the speed's noise.
TEST(DriveExport, RefusesWhatItCannotExport) {
  TempDir dir;
  const std::string config = testing::SourcePath("configs/two-mass-prbs.json");
  const std::string report = dir.File("tm.json");
  ASSERT_EQ(testing::Run(BinPath("blmd-sim") + " --config " + config + " --out " +
                         dir.File("tm.csv") + " --noise w=0.5% --quiet")
                .exit_code,
            0);
  json fit_config = json::parse(testing::Slurp(config));
  fit_config["identification"] = {{"free", {"J", "B", "anti_resonance_hz", "inertia_ratio"}},
                                  {"observe", {"w"}}};
  const std::string fit_path = dir.Write("tm-fit.json", fit_config.dump(2));
  ASSERT_EQ(testing::Run(BinPath("blmd-ident") + " --config " + fit_path + " --trace " +
                         dir.File("tm.csv") + " --report " + report + " --quiet")
                .exit_code,
            0);
  auto run = testing::Run(BinPath("blmd-export") + " --config " + fit_path + " --from-report " +
                          report + " --format c --out " + dir.File("c"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("two_mass has states of its own (a flexible coupling's load side)"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(testing::FileExists(dir.File("c")));
  run = testing::Run(BinPath("blmd-export") + " --config " + fit_path + " --from-report " + report +
                     " --format odrive --out " + dir.File("o.json"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_FALSE(testing::FileExists(dir.File("o.json")));
  run = testing::Run(BinPath("blmd-export") + " --config " + fit_path + " --format c --out " +
                     dir.File("c"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--from-report is required"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace blmd
