// blmd-ident --batch (docs/fleet.md): one identification per manifest row. A row is run as the
// command would run `blmd-ident --config C --trace T [--baseline B] <the batch's flags>
// <the row's args>`: its flags are parsed by the command's own flag set (ident_flags.h) and it
// runs through the same library calls, in this process. The command runs the rows on threads
// (RunBatch); the Python package's blmd.fleet.run runs RunFleetRow as Dask tasks. Both finish
// the folder with WriteFleetOutputs (app/fleet.h), so their tables agree.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "blmd/app/fleet.h"
#include "blmd/io/files.h"
#include "ident_flags.h"
#include "parallel.h"

namespace blmd::app {

// The flags that are the batch's own, not every row's: taking a value or not.
inline const std::vector<std::string>& BatchValueFlags() {
  static const std::vector<std::string> flags = {"--batch", "--out", "--baseline-dir",
                                                 "--drift-alpha", "--threads"};
  return flags;
}
inline const std::vector<std::string>& BatchSwitchFlags() {
  static const std::vector<std::string> flags = {"--new-baselines", "--progress", "--no-progress",
                                                 "--quiet"};
  return flags;
}
// The flags a row cannot take: its files are the batch's (<out>/<id>.json), --config,
// --trace and --baseline come from its columns.
inline const std::vector<std::string>& RowForbiddenFlags() {
  static const std::vector<std::string> flags = {
      "--config",       "--trace",         "--report",      "--html",    "--json",
      "--write-config", "--export-matlab", "--baseline",    "--batch",   "--out",
      "--baseline-dir", "--new-baselines", "--drift-alpha", "--threads", "--progress",
      "--no-progress",  "--quiet",         "--init-config"};
  return flags;
}

// The flag of an argument: "--x" of "--x" and "--x=v"; "" for a value.
inline std::string FlagOf(const std::string& arg) {
  if (arg.rfind("--", 0) != 0) return "";
  return arg.substr(0, arg.find('='));
}

// The batch command line without its own flags: what every row gets.
inline std::vector<std::string> CommonRowArguments(const std::vector<std::string>& args) {
  std::vector<std::string> out;
  const auto& values = BatchValueFlags();
  const auto& switches = BatchSwitchFlags();
  for (std::size_t k = 0; k < args.size(); ++k) {
    const std::string flag = FlagOf(args[k]);
    if (std::find(values.begin(), values.end(), flag) != values.end()) {
      if (args[k].find('=') == std::string::npos) ++k;  // its value follows
      continue;
    }
    if (std::find(switches.begin(), switches.end(), flag) != switches.end()) continue;
    out.push_back(args[k]);
  }
  return out;
}

// Refuses, with the flag named, what a batch's command line or a row's args cannot hold.
inline void CheckRowArguments(const std::vector<std::string>& args, const std::string& where) {
  const auto& forbidden = RowForbiddenFlags();
  for (const std::string& arg : args) {
    const std::string flag = FlagOf(arg);
    if (std::find(forbidden.begin(), forbidden.end(), flag) != forbidden.end()) {
      throw InputError(where + flag +
                       ": not for a batch row (config, trace and baseline are the manifest's "
                       "columns; each row's report is written to --out; docs/fleet.md)");
    }
  }
}

struct BatchOptions {
  std::string out_dir, baseline_dir;
  DriftRule rule;
  int row_threads = 1;  // each row's --threads
};

// Runs one row (or takes its stored line when its inputs are unchanged: *reused then true).
// Never throws for the row's own trouble: that is an error line. The line is stored in
// out_dir/rows/<id>.json, except for a manifest error (not the row's to resume) and a failure
// that is not the input's (a full disk, no memory, an internal error: run again next time).
inline nlohmann::json RunFleetRow(const FleetRow& row, const std::vector<std::string>& common,
                                  const BatchOptions& options, bool* reused = nullptr) {
  if (reused) *reused = false;
  if (!row.error.empty()) return FleetErrorResult(row, row.error);
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const std::string baseline = FleetBaseline(row, options.baseline_dir);
  const std::string key = FleetRowKey(row, baseline, common);
  if (std::optional<nlohmann::json> stored = StoredFleetRow(options.out_dir, row.id, key)) {
    if (reused) *reused = true;
    return *stored;
  }
  nlohmann::json line;
  bool finished = true;  // an input's error is final for these inputs; others are tried again
  try {
    CheckRowArguments(row.args, "args: ");
    std::vector<std::string> args = {"--config", row.config};
    for (const std::string& trace : row.traces) args.insert(args.end(), {"--trace", trace});
    if (!baseline.empty()) args.insert(args.end(), {"--baseline", baseline});
    args.insert(args.end(), common.begin(), common.end());
    args.insert(args.end(), row.args.begin(), row.args.end());
    args.insert(args.end(), {"--threads", std::to_string(options.row_threads)});
    CLI::App app{"blmd-ident row"};
    IdentFlags flags;
    flags.Add(app);
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11's order
    try {
      app.parse(reversed);
      RefuseEmptyValues(app, {"--observe", "--free", "--candidates"});
    } catch (const CLI::ParseError& error) {
      throw InputError(std::string("flags: ") + InputError::OneLine(error.what()));
    }
    IdentRequest request =
        MakeIdentRequest(LoadConfig(flags.config_path), flags.config_path, Settings(app, flags));
    const IdentOutcome outcome = Identify(std::move(request));
    const std::string report_file = row.id + ".json";
    WriteFileAtomically(FleetReportPath(options.out_dir, row.id),
                        nlohmann::json(outcome.report).dump(2) + "\n");
    // The table's line from the typed report, not from the JSON just written.
    line = FleetResultFromReport(row, outcome.report, report_file, options.rule, seconds());
    // A failed fit or gate is the row's error; drift is judged by the batch's rule (the
    // --baseline's own per-parameter verdict stays in the report).
    const IdentVerdict verdict = Judge(flags, outcome, /*with_baseline=*/false);
    if (verdict.code != kExitOk) {
      line["status"] = "error";
      line["message"] = verdict.message;
    }
  } catch (const InputError& error) {
    line = FleetErrorResult(row, error.what(), seconds());
  } catch (const OutputError& error) {
    line = FleetErrorResult(row, error.what(), seconds());
    finished = false;
  } catch (const std::bad_alloc&) {
    line = FleetErrorResult(row, "out of memory", seconds());
    finished = false;
  } catch (const std::exception& error) {
    line = FleetErrorResult(row, std::string("internal: ") + InputError::OneLine(error.what()),
                            seconds());
    finished = false;
  }
  // A row that failed before its fit leaves no report: an earlier run's is not this one's.
  if (line.value("report", "").empty())
    std::remove(FleetReportPath(options.out_dir, row.id).c_str());
  if (finished) StoreFleetRow(options.out_dir, row.id, key, line);
  return line;
}

// The batch's progress on stderr: one line redrawn on a terminal, a line per finished row
// otherwise.
class BatchProgress {
 public:
  BatchProgress(std::size_t rows, bool terminal) : rows_(rows), terminal_(terminal) {}
  void Row(const nlohmann::json& line, bool reused) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++done_;
    if (reused) ++reused_;
    const std::string status = line.value("status", "");
    if (status == "error") ++error_;
    if (status == "drift") ++drift_;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const std::size_t ran = done_ - reused_;
    const double left =
        ran > 0 ? elapsed / static_cast<double>(ran) * static_cast<double>(rows_ - done_) : 0.0;
    std::fprintf(stderr,
                 "%sblmd-ident: batch %zu/%zu rows (%zu drift, %zu error, %zu unchanged), "
                 "%.0f s, about %.0f s left%s",
                 terminal_ ? "\r" : "", done_, rows_, drift_, error_, reused_, elapsed, left,
                 terminal_ ? "\033[K" : "\n");
    if (terminal_ && done_ == rows_) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  std::mutex mutex_;
  const std::size_t rows_;
  const bool terminal_;
  std::size_t done_ = 0, reused_ = 0, error_ = 0, drift_ = 0;
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

struct BatchRun {
  FleetSummary summary;
  std::size_t ran = 0, reused = 0;
};

// Runs every row of the manifest: rows in parallel on `threads` (0: every core), each row on
// threads / rows-at-once threads, then writes the table.
inline BatchRun RunBatch(const std::vector<FleetRow>& rows, const std::vector<std::string>& common,
                         BatchOptions options, int threads, bool store_baselines,
                         BatchProgress* progress) {
  const int total = internal::ThreadCount(threads);
  const int at_once = std::max(1, std::min<int>(total, static_cast<int>(rows.size())));
  options.row_threads = std::max(1, total / at_once);
  std::vector<char> reused(rows.size(), 0);
  std::vector<nlohmann::json> lines(rows.size());
  internal::ParallelFor(rows.size(), at_once, [&](std::size_t k) {
    bool was_reused = false;
    lines[k] = RunFleetRow(rows[k], common, options, &was_reused);
    reused[k] = was_reused ? 1 : 0;
    if (progress) progress->Row(lines[k], was_reused);
  });
  BatchRun run;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (!rows[k].error.empty()) continue;
    (reused[k] ? run.reused : run.ran) += 1;
  }
  run.summary = WriteFleetOutputs(rows, std::move(lines), options.out_dir, options.baseline_dir,
                                  store_baselines);
  return run;
}

}  // namespace blmd::app
