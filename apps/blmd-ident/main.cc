// blmd-ident: identify the free parameters of a config's model from measured traces.
// Flags -> IdentSettings -> blmd::MakeIdentRequest (app/request.h) -> blmd::Identify
// (app/identify.h) -> the report, summary, HTML and exit code (docs/cli.md); with --batch, one
// such identification per manifest row (batch.h, docs/fleet.md).
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include "../common/app_main.h"
#include "app/request.h"
#include "batch.h"
#include "blmd/app/fleet.h"
#include "blmd/app/identify.h"
#include "blmd/app/page_analysis.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/report/export.h"
#include "blmd/report/html/html_report.h"
#include "blmd/report/progress.h"
#include "blmd/report/report.h"
#include "ident_flags.h"

namespace {

using blmd::app::IdentFlags;

// --progress, --no-progress: the progress line on stderr (docs/cli.md §2.3), by default on a
// terminal only and not with --quiet; null when off.
std::unique_ptr<blmd::ProgressPrinter> MakeProgress(const IdentFlags& f) {
  const bool terminal = isatty(STDERR_FILENO) != 0;
  if (f.no_progress || !(f.progress || (terminal && !f.quiet))) return nullptr;
  int width = 0;  // a file: lines uncut
  winsize size{};
  if (terminal && ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0) width = size.ws_col;
  return std::make_unique<blmd::ProgressPrinter>(stderr, "blmd-ident: ", width);
}

// The output files (the HTML page computes its cost curves: a stage of the progress).
void WriteFiles(const IdentFlags& f, const blmd::IdentOutcome& outcome,
                const nlohmann::json& report_json, blmd::ProgressObserver* progress) {
  const blmd::IdentReport& report = outcome.report;
  if (!f.report_path.empty()) blmd::WriteFileAtomically(f.report_path, report_json.dump(2) + "\n");
  if (!f.write_config_path.empty()) {
    const nlohmann::json config = blmd::ModelConfigJson(
        outcome.final_config, outcome.final_parameters, outcome.final_free, report);
    blmd::WriteFileAtomically(f.write_config_path, config.dump(2) + "\n");
  }
  if (!f.matlab_path.empty()) blmd::WriteFileAtomically(f.matlab_path, blmd::MatlabScript(report));
  if (!f.html_path.empty()) {
    if (progress) progress->BeginStage("html report");
    blmd::HtmlReportOptions html_options;
    html_options.threads = f.threads;
    // The page's simulations and cost slices first (the analysis); the renderer runs nothing.
    const blmd::PageViews views = blmd::AnalysePage(*outcome.problem, outcome.first_fit,
                                                    outcome.discovery.get(), html_options);
    blmd::WriteHtmlReport(f.html_path, {&report, outcome.problem.get(), &views}, html_options);
  }
}

// The report on stdout (--json) or the summary.
void PrintOutputs(const IdentFlags& f, const blmd::IdentOutcome& outcome,
                  const nlohmann::json& report_json) {
  const blmd::IdentReport& report = outcome.report;
  if (f.json) {
    std::cout << report_json.dump(2) << "\n";
  } else if (!f.quiet) {
    std::cout << blmd::HumanSummary(report);
    if (!f.report_path.empty()) std::cout << "report: " << f.report_path << "\n";
    if (!f.html_path.empty()) std::cout << "html report: " << f.html_path << "\n";
    if (!f.write_config_path.empty()) std::cout << "config: " << f.write_config_path << "\n";
    if (!f.matlab_path.empty()) std::cout << "matlab: " << f.matlab_path << "\n";
  }
}

// The exit code (docs/errors.md) with its one line on stderr.
int ExitCode(const IdentFlags& f, const blmd::IdentOutcome& outcome) {
  const blmd::app::IdentVerdict verdict = blmd::app::Judge(f, outcome);
  if (verdict.code != blmd::kExitOk) std::cerr << "error: " << verdict.message << "\n";
  return verdict.code;
}

// --batch MANIFEST --out DIR (docs/fleet.md): every row one identification, the table in DIR.
int RunBatchCommand(const IdentFlags& f, const std::vector<std::string>& args) {
  if (f.out_dir.empty()) throw blmd::InputError("--batch needs --out DIR (the output folder)");
  if (f.new_baselines && f.baseline_dir.empty()) {
    throw blmd::InputError("--new-baselines needs --baseline-dir (where the baselines are kept)");
  }
  const std::vector<std::string> common = blmd::app::CommonRowArguments(args);
  blmd::app::CheckRowArguments(common, "");
  const std::vector<blmd::FleetRow> rows = blmd::ReadFleetManifest(f.batch_path);
  blmd::PrepareFleetFolder(f.out_dir);
  blmd::InstallCleanupOnSignal();
  blmd::app::BatchOptions options;
  options.out_dir = f.out_dir;
  options.baseline_dir = f.baseline_dir;
  options.rule.alpha = f.drift_alpha;
  const bool terminal = isatty(STDERR_FILENO) != 0;
  std::unique_ptr<blmd::app::BatchProgress> progress;
  if (!f.no_progress && (f.progress || (terminal && !f.quiet))) {
    progress = std::make_unique<blmd::app::BatchProgress>(rows.size(), terminal);
  }
  const auto start = std::chrono::steady_clock::now();
  const blmd::app::BatchRun run =
      blmd::app::RunBatch(rows, common, options, f.threads, f.new_baselines, progress.get());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const blmd::FleetSummary& s = run.summary;
  if (!f.quiet) {
    std::cout << "batch: " << s.rows << " rows: " << s.ok << " ok, " << s.drift << " drift, "
              << s.error << " error (" << run.ran << " run, " << run.reused
              << " unchanged since the last run) in " << blmd::DisplayNumber(seconds) << " s\n";
    if (s.baselines_stored > 0) {
      std::cout << "baselines stored: " << s.baselines_stored << " in " << f.baseline_dir << "\n";
    }
    std::cout << "results: " << f.out_dir << "/results.csv, " << f.out_dir << "/results.jsonl, "
              << f.out_dir << "/fleet.html\n";
  }
  return s.ExitCode();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"blmd-ident: identify J, B (and any other free parameter) from a recorded trace"};
  blmd::app::AddVersionFlag(app, "blmd-ident");
  blmd::app::AddHelpFooter(app, "blmd-ident");
  const std::vector<std::string> args(argv + std::min(argc, 1), argv + argc);
  // With --batch, --config and --trace come from the manifest's rows.
  const bool batch = std::any_of(args.begin(), args.end(), [](const std::string& a) {
    return blmd::app::FlagOf(a) == "--batch" || blmd::app::FlagOf(a) == "--init-config";
  });
  IdentFlags flags;
  flags.Add(app, batch);
  return blmd::app::Main(
      app, argc, argv,
      [&]() -> int {
        if (app.count("--init-config") > 0)
          return blmd::app::PrintStartingConfig(app, flags.init_model);
        flags.threads = blmd::app::CapThreads(flags.threads);
        if (!flags.batch_path.empty()) return RunBatchCommand(flags, args);
        // Every output checked before any work: writable, not an input, not another output.
        std::vector<blmd::NamedPath> input_files = {{"--config", flags.config_path}};
        for (const auto& path : flags.traces) input_files.push_back({"--trace", path});
        for (const auto& path : flags.validates) input_files.push_back({"--validate", path});
        if (!flags.baseline_path.empty())
          input_files.push_back({"--baseline", flags.baseline_path});
        blmd::CheckOutputs({{"--report", flags.report_path},
                            {"--html", flags.html_path},
                            {"--write-config", flags.write_config_path},
                            {"--export-matlab", flags.matlab_path}},
                           input_files);
        blmd::IdentRequest request = blmd::MakeIdentRequest(
            blmd::LoadConfig(flags.config_path), flags.config_path, Settings(app, flags));
        if (!flags.report_path.empty() || !flags.html_path.empty() ||
            !flags.write_config_path.empty() || !flags.matlab_path.empty()) {
          blmd::InstallCleanupOnSignal();
        }
        // The progress line ends before anything is printed on stdout (same terminal).
        std::unique_ptr<blmd::ProgressPrinter> progress = MakeProgress(flags);
        request.options.progress = progress.get();
        const blmd::IdentOutcome outcome = blmd::Identify(std::move(request));
        const nlohmann::json report_json = outcome.report;
        WriteFiles(flags, outcome, report_json, progress.get());
        if (progress) progress->Finish();
        PrintOutputs(flags, outcome, report_json);
        return ExitCode(flags, outcome);
      },
      {"--observe", "--free", "--candidates"});
}
