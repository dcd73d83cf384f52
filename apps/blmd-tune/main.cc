// blmd-tune: PI (speed loop) or PID (position loop) gains from the identified model for a
// requested crossover and phase margin, checked over the parameters' 95 % box and on the
// nonlinear model in closed loop (docs/tuning.md, docs/cli.md §4).
// Flags -> TuneSettings -> blmd::RunTune (app/tune_run.h: the plant, the request, the tuning)
// -> the typed report, rendered as JSON, the closed-loop config and the summary; the exit code.
#include <iostream>

#include "../common/app_main.h"
#include "app/tune_run.h"
#include "blmd/io/files.h"
#include "tune_flags.h"

namespace {

using blmd::app::TuneFlags;

int Run(const CLI::App& app, TuneFlags& f) {
  f.threads = blmd::app::CapThreads(f.threads);
  blmd::CheckOutputs({{"--report", f.report_path}, {"--write-config", f.write_config_path}},
                     {{"--config", f.config_path}, {"--from-report", f.report_in_path}});
  if (!f.report_path.empty() || !f.write_config_path.empty()) blmd::InstallCleanupOnSignal();
  const blmd::TuneReport tuned =
      blmd::RunTune(f.config_path, f.report_in_path, TuneSettingsOf(app, f));
  if (tuned.result.refused) {
    // A request the plant cannot meet: exit 1, the reason, nothing written.
    std::cerr << "error: cannot tune: " << tuned.result.refusal << "\n";
    return blmd::kExitFailed;
  }
  const nlohmann::json report = tuned;
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report.dump(2) + "\n");
  if (!f.write_config_path.empty()) {
    const nlohmann::json config = blmd::ClosedLoopConfigJson(tuned);
    blmd::WriteFileAtomically(f.write_config_path, config.dump(2) + "\n");
  }
  if (f.json) {
    std::cout << report.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::TuneSummary(tuned);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (!f.write_config_path.empty()) std::cout << "config: " << f.write_config_path << "\n";
  }
  if (f.fail_on_warning && !tuned.result.warnings.empty()) return blmd::kExitGate;
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-tune: PI or PID gains from the identified model for a crossover and phase margin, "
      "checked over the parameters' 95 % box"};
  blmd::app::AddVersionFlag(app, "blmd-tune");
  blmd::app::AddHelpFooter(app, "blmd-tune");
  TuneFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(app, flags); });
}
