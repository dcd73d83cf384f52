// blmd-design: which experiment to run. Flags -> DesignSettings -> blmd::MakeDesignRequest
// (report/design_report.h) -> blmd::RunDesign -> the report, the config, the input table, the
// summary and the exit code (docs/cli.md §5, docs/design.md).
#include <iostream>
#include <optional>

#include "../common/app_main.h"
#include "../common/trace_flags.h"
#include "app/experiment_design_run.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "design_flags.h"

namespace {

using blmd::app::DesignFlags;

int Run(const CLI::App& app, DesignFlags& f) {
  f.threads = blmd::app::CapThreads(f.threads);
  if (f.trace_path.empty()) {
    for (const char* flag : {"--column", "--scale", "--derive", "--select", "--split",
                             "--initial-state", "--resample"}) {
      if (app.count(flag) > 0) {
        throw blmd::InputError(std::string(flag) + ": only with --trace (it prepares the trace)");
      }
    }
  }
  if (!f.trace_path.empty()) {
    for (const char* flag : {"--write-config", "--write-input"}) {
      if (app.count(flag) > 0) {
        throw blmd::InputError(std::string(flag) +
                               ": not with --trace (a recorded input is evaluated, not designed)");
      }
    }
  }
  blmd::CheckOutputs(
      {{"--report", f.report_path},
       {"--write-config", f.write_config_path},
       {"--write-input", f.write_input_path}},
      {{"--config", f.config_path}, {"--trace", f.trace_path}, {"--from-report", f.from_report}});
  const blmd::Config config = blmd::LoadConfig(f.config_path);
  const blmd::DesignRequest request =
      blmd::MakeDesignRequest(config, f.config_path, DesignSettingsOf(app, f));
  if (!f.report_path.empty() || !f.write_config_path.empty() || !f.write_input_path.empty()) {
    blmd::InstallCleanupOnSignal();
  }
  const blmd::DesignReport report = blmd::RunDesign(request);
  const nlohmann::json report_json = blmd::DesignReportJson(report);
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report_json.dump(2) + "\n");
  if (report.ok && !f.write_config_path.empty()) {
    blmd::WriteFileAtomically(
        f.write_config_path, blmd::DesignConfigJson(request.problem.config, report).dump(2) + "\n");
  }
  if (report.ok && !f.write_input_path.empty()) {
    blmd::WriteTraceCsv(blmd::DesignInputTable(report), f.write_input_path);
  }
  if (f.json) {
    std::cout << report_json.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::DesignSummary(report);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (report.ok && !f.write_config_path.empty())
      std::cout << "config: " << f.write_config_path << "\n";
    if (report.ok && !f.write_input_path.empty())
      std::cout << "input: " << f.write_input_path << "\n";
  }
  if (!report.ok) {
    std::cerr << "error: no design: " << report.reason << "\n";
    return blmd::kExitFailed;
  }
  if (f.fail_on_warning && !report.warnings.empty()) return blmd::kExitGate;
  return blmd::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "blmd-design: which experiment to run: the predicted precision of J, B (and any "
      "free parameter) and the input that maximises it within the drive's limits"};
  blmd::app::AddVersionFlag(app, "blmd-design");
  blmd::app::AddHelpFooter(app, "blmd-design");
  DesignFlags flags;
  flags.Add(app);
  return blmd::app::Main(app, argc, argv, [&]() -> int { return Run(app, flags); });
}
