// blmd-export: an identification report's final model into the drive (docs/export.md §6): the
// feed-forward torque as portable C99 (with the online J tracker, §7), as an ODrive
// configuration, or as a MuJoCo joint. Flags -> the config and the report (ApplyFinalModel)
// -> Compensation -> the files; exit 2 on bad input with nothing written.
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include "../common/app_main.h"
#include "../common/tracker_flags.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/io/stored_report.h"
#include "tune/compensation.h"
#include "tune/inertia_tracker.h"

namespace {

struct ExportFlags {
  std::string config_path, report_path, format, out_path;
  int cogging_points = 3600;
  double tracker_rate = 0.0;
  blmd::app::TrackerFlags tracker;
  bool quiet = false;

  void Add(CLI::App& app) {
    app.add_option("--config", config_path, "the config that was identified (JSON)")->required();
    app.add_option("--from-report", report_path, "the identification report (blmd-ident --report)")
        ->required();
    app.add_option("--format", format,
                   "c: a C99 header and source of the feed-forward and the J tracker, written "
                   "into the folder OUT; odrive: ODrive's settings (JSON); mujoco: a MuJoCo joint "
                   "(MJCF XML)")
        ->required()
        ->check(CLI::IsMember({"c", "odrive", "mujoco"}));
    app.add_option("--out", out_path, "the folder (--format c) or the file to write")->required();
    app.add_option("--cogging-points", cogging_points,
                   "--format c: cogging table points per revolution (default 3600)")
        ->check(CLI::Range(16, 65536));
    app.add_option("--tracker-rate", tracker_rate,
                   "--format c: the rate (Hz) the firmware calls the J tracker at (default: "
                   "the J tracker is left out)")
        ->check(blmd::app::PositiveNumber());
    tracker.Add(app, "tracker: ");
    app.add_flag("--quiet", quiet, "print nothing on success");
  }
};

int Run(const ExportFlags& f) {
  blmd::CheckOutputs({{"--out", f.out_path}},
                     {{"--config", f.config_path}, {"--from-report", f.report_path}});
  const blmd::Config config = blmd::LoadConfig(f.config_path);
  const blmd::StoredReport report =
      blmd::StoredReport::Load(f.report_path, "identification report");
  const blmd::Compensation compensation = blmd::Compensation::FromReport(config, report);
  std::string written;
  if (f.format == "c") {
    const blmd::CFiles files = blmd::CompensationC(compensation, f.cogging_points);
    std::optional<blmd::CFiles> tracker_files;
    if (f.tracker_rate > 0.0) {
      const blmd::SpeedNoise noise = blmd::SpeedNoiseOf(f.tracker, report);
      if (!(noise.sigma > 0.0)) {
        throw blmd::InputError(
            "--tracker-rate: the report gives no noise for w: give the speed's noise std "
            "(--speed-noise SIGMA, rad/s) so that the tracker can tell motion from noise");
      }
      tracker_files = blmd::TrackerC(
          blmd::MakeTrackerSeed(compensation, f.tracker, 1.0 / f.tracker_rate, noise.sigma));
    }
    std::error_code error;
    std::filesystem::create_directories(f.out_path, error);
    if (error) throw blmd::OutputError(f.out_path + ": cannot make the folder: " + error.message());
    const std::filesystem::path out(f.out_path);
    blmd::WriteFileAtomically((out / "blmd_compensation.h").string(), files.header);
    blmd::WriteFileAtomically((out / "blmd_compensation.c").string(), files.source);
    written = (out / "blmd_compensation.h").string() + ", blmd_compensation.c";
    if (tracker_files) {
      blmd::WriteFileAtomically((out / "blmd_tracker.h").string(), tracker_files->header);
      blmd::WriteFileAtomically((out / "blmd_tracker.c").string(), tracker_files->source);
      written += ", blmd_tracker.h, blmd_tracker.c";
    }
  } else if (f.format == "odrive") {
    blmd::WriteFileAtomically(f.out_path, blmd::ODriveSettings(compensation));
    written = f.out_path;
  } else {
    blmd::WriteFileAtomically(f.out_path, blmd::MujocoModel(compensation));
    written = f.out_path;
  }
  if (!f.quiet) {
    std::cout << "blmd-export: " << compensation.model << " '" << compensation.config_name
              << "' from " << f.report_path << " (" << f.format << ") -> " << written << "\n";
  }
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-export: an identified model into the drive: feed-forward (C99, ODrive, MuJoCo) and "
      "the online J tracker"};
  blmd::app::AddVersionFlag(app, "blmd-export");
  blmd::app::AddHelpFooter(app, "blmd-export");
  ExportFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(flags); });
}
