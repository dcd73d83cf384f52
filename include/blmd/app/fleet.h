// A fleet of drives (docs/fleet.md): one identification per row of a manifest, each row's
// result as one line of a table, a drift rule per drive against its own baseline, and the
// files a batch leaves in its output folder. blmd-ident --batch runs the rows on threads,
// the Python package's blmd.fleet.run as Dask tasks; both run a row through the same code
// (apps/blmd-ident/batch.h) and finish the folder with WriteFleetOutputs, so their tables
// agree line for line.
//
// The output folder:
//   <id>.json           each row's blmd-ident report (rows that ran)
//   rows/<id>.json      each finished row: its inputs' key and its line of the table
//   results.csv         the table, one line per manifest row, in the manifest's order
//   results.jsonl       the same lines as JSON objects
//   fleet.html          each drive's parameters over its records, flagged drives first
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "blmd/report/report.h"

namespace blmd {

// One row of the manifest (header `id,trace,config,baseline`, and optionally `drive`, `date`
// and `args`; docs/fleet.md).
struct FleetRow {
  long line = 0;                    // the manifest's line (the header is line 1)
  std::string id;                   // unique in the manifest; names the row's files
  std::string drive;                // the drive the record is of (default: the id)
  std::string date;                 // when it was recorded, as text (ISO 8601 sorts by time)
  std::string config;               // resolved against the manifest's folder
  std::vector<std::string> traces;  // `trace`: several separated by ';'
  std::string baseline;             // a report of this drive, or "" (then --baseline-dir's, if any)
  std::vector<std::string> args;    // more blmd-ident flags for this row (`args`, shell words)
  std::string error;                // the row cannot run: why (an error row; never a failed batch)
};

// Reads the manifest. Throws InputError (file, line, column) when the file cannot be read or
// its header lacks `id`, `trace` or `config`; a bad row (an empty or repeated id, an id with
// characters other than letters, digits, '.', '_' and '-', a missing trace or config, an
// unclosed quote in `args`) is returned with `error` set.
std::vector<FleetRow> ReadFleetManifest(const std::string& path);

// Words of a shell-like argument string: separated by blanks, '...' and "..." quote (a
// backslash escapes the next character outside single quotes). nullopt when a quote is not
// closed.
std::optional<std::vector<std::string>> SplitArguments(const std::string& text);

// What decides that a finished row need not run again: a SHA-256 of the tool's version, the
// row's id, drive and date, its arguments (the batch's common flags and its own), the baseline it
// is compared with and the bytes of every file it reads (config, traces, baseline). A file that
// cannot be read enters as its name and the reason, so that it is read again (and fails) next time.
std::string FleetRowKey(const FleetRow& row, const std::string& baseline_path,
                        const std::vector<std::string>& common_args);

// The drift rule (docs/fleet.md "Drift"): each parameter compared with the baseline has
// z = |shift| / sigma, sigma the combined standard error (the combined 95 % half-width of the
// report's baseline block over 1.96); the drive drifted when the largest z exceeds the
// normal quantile 1 - alpha / (2 k) for the k parameters compared (Bonferroni), so that a
// drive that did not change is flagged with a probability of at most alpha.
struct DriftRule {
  double alpha = 0.01;
  double Threshold(std::size_t compared) const;
};

// A row's line of the table from its typed blmd-ident report (what --report writes is its
// rendering): the status (`ok` or `drift`), the free parameters with their 95 % intervals, the
// NRMSE, drift_z and its threshold, the effects discovery added, the warnings' codes.
// `report_file` is the report's path relative to the output folder.
nlohmann::json FleetResultFromReport(const FleetRow& row, const IdentReport& report,
                                     const std::string& report_file, const DriftRule& rule,
                                     double wall_time_s);
// An error row: status `error` and the message.
nlohmann::json FleetErrorResult(const FleetRow& row, const std::string& message,
                                double wall_time_s = 0.0);

// Files of the output folder.
std::string FleetReportPath(const std::string& out_dir, const std::string& id);
std::string FleetRowPath(const std::string& out_dir, const std::string& id);
// Creates out_dir and out_dir/rows (InputError when it cannot).
void PrepareFleetFolder(const std::string& out_dir);
// A finished row: its key and line (written atomically: a row is finished or absent).
void StoreFleetRow(const std::string& out_dir, const std::string& id, const std::string& key,
                   const nlohmann::json& result);
// The stored line of a row whose key is `key`; nullopt when the row has not finished with
// these inputs (no file, another key, an unreadable file).
std::optional<nlohmann::json> StoredFleetRow(const std::string& out_dir, const std::string& id,
                                             const std::string& key);

// The baseline a row is compared with: its `baseline` column, else <baseline_dir>/<drive>.json
// when that exists, else "".
std::string FleetBaseline(const FleetRow& row, const std::string& baseline_dir);

struct FleetSummary {
  std::size_t rows = 0, ok = 0, drift = 0, error = 0;
  std::size_t baselines_stored = 0;
  int ExitCode() const;  // 1 when a row failed, else 3 when one drifted, else 0
};

// Writes results.csv, results.jsonl and fleet.html from the rows' lines (lines[k] of rows[k];
// a row without a line is an error row "did not finish"), in the manifest's order. With
// `store_baselines` and a `baseline_dir`, a drive that has no baseline there gets the report
// of its first `ok` row without a baseline (in the manifest's order). Returns the counts.
FleetSummary WriteFleetOutputs(const std::vector<FleetRow>& rows, std::vector<nlohmann::json> lines,
                               const std::string& out_dir, const std::string& baseline_dir,
                               bool store_baselines);

// The table's columns for these lines: the fixed ones, then each other parameter's value and
// interval (sorted by name).
std::vector<std::string> FleetColumns(const std::vector<nlohmann::json>& lines);
std::string FleetCsv(const std::vector<nlohmann::json>& lines);

}  // namespace blmd
