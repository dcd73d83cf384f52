#include "blmd/app/fleet.h"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/report/html/fleet_page.h"
#include "blmd/version.h"

namespace blmd {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kZ95 = 1.959963984540054;  // the normal 97.5 % quantile

bool SafeName(const std::string& name) {
  if (name.empty() || name == "." || name == "..") return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
  });
}

std::string Trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

// One CSV line's fields (RFC 4180 quotes within the line) and the 1-based column where each
// starts; nullopt when a quote is not closed.
struct Fields {
  std::vector<std::string> values;
  std::vector<long> columns;
};
std::optional<Fields> SplitCsvLine(const std::string& line) {
  Fields out;
  std::string field;
  bool quoted = false;
  long start = 1;
  for (std::size_t k = 0; k < line.size(); ++k) {
    const char c = line[k];
    if (quoted) {
      if (c == '"' && k + 1 < line.size() && line[k + 1] == '"') {
        field += '"';
        ++k;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.values.push_back(Trimmed(field));
      out.columns.push_back(start);
      field.clear();
      start = static_cast<long>(k) + 2;
    } else {
      field += c;
    }
  }
  if (quoted) return std::nullopt;
  out.values.push_back(Trimmed(field));
  out.columns.push_back(start);
  return out;
}

std::string Resolve(const fs::path& folder, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute()) return path;
  return (folder / path).lexically_normal().string();
}

// A file into the hash: its name and its bytes' SHA-256; a file that cannot be read enters
// as the reason.
void HashFile(Sha256* hash, const std::string& path) {
  std::string digest;
  try {
    digest = Sha256OfFile(path);
  } catch (const InputError& error) {
    digest = std::string("unreadable: ") + error.what();
  }
  hash->Update(path + std::string(1, '\0') + digest + std::string(1, '\0'));
}

const std::vector<std::string> kFixedColumns = {"id",
                                                "drive",
                                                "date",
                                                "status",
                                                "J",
                                                "J_ci95_low",
                                                "J_ci95_high",
                                                "B",
                                                "B_ci95_low",
                                                "B_ci95_high",
                                                "nrmse",
                                                "drift_z",
                                                "drift_threshold",
                                                "moved",
                                                "effects",
                                                "warnings",
                                                "message",
                                                "J_baseline",
                                                "J_baseline_ci95_low",
                                                "J_baseline_ci95_high",
                                                "B_baseline",
                                                "B_baseline_ci95_low",
                                                "B_baseline_ci95_high",
                                                "wall_time_s",
                                                "report"};

std::string CsvCell(const json& value) {
  if (value.is_null()) return "";
  if (value.is_number()) {
    char text[40];
    std::snprintf(text, sizeof text, "%.10g", value.get<double>());
    return text;
  }
  const std::string s = value.is_string() ? value.get<std::string>() : value.dump();
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

}  // namespace

std::optional<std::vector<std::string>> SplitArguments(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  char quote = 0;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (quote == '\'') {
      if (c == '\'') {
        quote = 0;
      } else {
        word += c;
      }
    } else if (quote == '"') {
      if (c == '"') {
        quote = 0;
      } else if (c == '\\' && k + 1 < text.size()) {
        word += text[++k];
      } else {
        word += c;
      }
    } else if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (c == '\\' && k + 1 < text.size()) {
      word += text[++k];
      in_word = true;
    } else if (c == ' ' || c == '\t') {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (quote != 0) return std::nullopt;
  if (in_word) words.push_back(word);
  return words;
}

std::vector<FleetRow> ReadFleetManifest(const std::string& path) {
  const std::string text = ReadFileText(path, std::size_t{256} << 20, "manifest");
  const fs::path folder = fs::path(path).parent_path();
  std::vector<FleetRow> rows;
  std::map<std::string, std::size_t> column_of;  // name -> field index
  std::map<std::string, long> first_line;        // id -> line
  const std::vector<std::string> known = {"id",    "trace", "config", "baseline",
                                          "drive", "date",  "args"};
  std::istringstream in(text);
  std::string line;
  long number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trimmed(line).empty() || Trimmed(line)[0] == '#') continue;
    const std::optional<Fields> fields = SplitCsvLine(line);
    if (!header) {
      if (!fields) throw InputError(path, number, 1, "unclosed quote in the header");
      for (std::size_t k = 0; k < fields->values.size(); ++k) {
        const std::string& name = fields->values[k];
        if (std::find(known.begin(), known.end(), name) == known.end()) {
          throw InputError(path, number, fields->columns[k],
                           "unknown column '" + InputError::Excerpt(name) +
                               "' (the manifest's columns: " + Join(known, ", ") + ")");
        }
        if (column_of.count(name)) {
          throw InputError(path, number, fields->columns[k], "column '" + name + "' repeats");
        }
        column_of[name] = k;
      }
      for (const char* needed : {"id", "trace", "config"}) {
        if (!column_of.count(needed)) {
          throw InputError(path, number, 1,
                           std::string("the header has no column '") + needed +
                               "' (a manifest's header: id,trace,config,baseline; docs/fleet.md)");
        }
      }
      header = true;
      continue;
    }
    FleetRow row;
    row.line = number;
    if (!fields) {
      row.id = "line" + std::to_string(number);
      row.error = path + ":" + std::to_string(number) + ": unclosed quote";
      rows.push_back(row);
      continue;
    }
    auto cell = [&](const std::string& name) -> std::string {
      const auto it = column_of.find(name);
      if (it == column_of.end() || it->second >= fields->values.size()) return "";
      return fields->values[it->second];
    };
    auto where = [&](const std::string& name) {
      const auto it = column_of.find(name);
      const long column = it != column_of.end() && it->second < fields->columns.size()
                              ? fields->columns[it->second]
                              : 1;
      return path + ":" + std::to_string(number) + ":" + std::to_string(column) + ": ";
    };
    row.id = cell("id");
    row.drive = cell("drive").empty() ? row.id : cell("drive");
    row.date = cell("date");
    row.config = Resolve(folder, cell("config"));
    row.baseline = Resolve(folder, cell("baseline"));
    std::string traces = cell("trace");
    std::size_t start = 0;
    while (start <= traces.size()) {
      const std::size_t end = std::min(traces.find(';', start), traces.size());
      const std::string one = Trimmed(traces.substr(start, end - start));
      if (!one.empty()) row.traces.push_back(Resolve(folder, one));
      start = end + 1;
    }
    const std::optional<std::vector<std::string>> args = SplitArguments(cell("args"));
    if (args) row.args = *args;
    if (fields->values.size() > column_of.size()) {
      row.error = where("id") + "the row has " + std::to_string(fields->values.size()) +
                  " fields, the header " + std::to_string(column_of.size());
    } else if (!SafeName(row.id)) {
      row.error =
          where("id") +
          (row.id.empty() ? std::string("empty id") : "id '" + InputError::Excerpt(row.id) + "'") +
          ": an id names the row's files (letters, digits, '.', '_', '-')";
      if (row.id.empty() || !SafeName(row.id)) row.id = "line" + std::to_string(number);
    } else if (first_line.count(row.id)) {
      row.error =
          where("id") + "id '" + row.id + "' repeats line " + std::to_string(first_line[row.id]);
    } else if (!SafeName(row.drive)) {
      row.error = where("drive") + "drive '" + InputError::Excerpt(row.drive) +
                  "': a drive names its baseline file (letters, digits, '.', '_', '-')";
    } else if (row.traces.empty()) {
      row.error = where("trace") + "no trace";
    } else if (row.config.empty()) {
      row.error = where("config") + "no config";
    } else if (!args) {
      row.error = where("args") + "unclosed quote in args";
    }
    if (!first_line.count(row.id)) first_line[row.id] = number;
    rows.push_back(row);
  }
  if (!header)
    throw InputError(path, 1, 1, "no header (a manifest's header: id,trace,config,baseline)");
  return rows;
}

std::string FleetRowKey(const FleetRow& row, const std::string& baseline_path,
                        const std::vector<std::string>& common_args) {
  Sha256 hash;
  const std::string zero(1, '\0');
  hash.Update(std::string("blmd-ident ") + kVersion + zero + row.id + zero + row.drive + zero +
              row.date + zero);
  for (const auto& a : common_args) hash.Update(a + zero);
  hash.Update("--row" + zero);
  for (const auto& a : row.args) hash.Update(a + zero);
  HashFile(&hash, row.config);
  for (const auto& t : row.traces) HashFile(&hash, t);
  if (!baseline_path.empty()) HashFile(&hash, baseline_path);
  return hash.HexDigest();
}

double DriftRule::Threshold(std::size_t compared) const {
  if (compared == 0) return NAN;
  const boost::math::normal normal;
  return boost::math::quantile(normal, 1.0 - alpha / (2.0 * static_cast<double>(compared)));
}

json FleetResultFromReport(const FleetRow& row, const IdentReport& report,
                           const std::string& report_file, const DriftRule& rule,
                           double wall_time_s) {
  json line = FleetErrorResult(row, "", wall_time_s);
  line["status"] = "ok";
  line["report"] = report_file;
  // The table's numbers as the report states them: a value that is not finite is null.
  const auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  for (const auto& [name, p] : report.final_model.parameters) {
    if (!p.free) continue;
    const ParameterEstimate& e = p.estimate;
    line[name] = number(e.value);
    line[name + "_ci95_low"] = e.has_interval ? number(e.ci95_low) : json(nullptr);
    line[name + "_ci95_high"] = e.has_interval ? number(e.ci95_high) : json(nullptr);
  }
  const ErrorFigures& errors = report.final_model.fit.errors;
  line["nrmse"] = errors.ok ? number(errors.nrmse) : json(nullptr);
  std::vector<std::string> codes, effects;
  for (const Warning& w : report.warnings) codes.push_back(w.code);
  if (report.discovery) effects = report.discovery->added;
  line["warnings"] = Join(codes, ";");
  line["effects"] = Join(effects, ";");
  if (report.baseline) {
    // By name, as the report's JSON lists them (the worst shift's name breaks ties alike).
    std::vector<BaselineParameter> parameters = report.baseline->parameters;
    std::sort(
        parameters.begin(), parameters.end(),
        [](const BaselineParameter& a, const BaselineParameter& b) { return a.name < b.name; });
    // Each compared parameter's shift in standard errors of the difference.
    std::vector<std::pair<const BaselineParameter*, double>> z_of;
    for (const BaselineParameter& p : parameters) {
      const bool compared = p.verdict != "not_compared";
      if (p.name == "J" || p.name == "B") {
        line[p.name + "_baseline"] = number(p.baseline);
        line[p.name + "_baseline_ci95_low"] =
            compared ? number(p.baseline_ci95_low) : json(nullptr);
        line[p.name + "_baseline_ci95_high"] =
            compared ? number(p.baseline_ci95_high) : json(nullptr);
      }
      if (!compared) continue;
      if (std::isfinite(p.shift) && std::isfinite(p.combined_limit) && p.combined_limit > 0.0)
        z_of.emplace_back(&p, std::abs(p.shift) / (p.combined_limit / kZ95));
    }
    const std::size_t compared = z_of.size();
    double z_max = NAN;
    const BaselineParameter* worst = nullptr;
    for (const auto& [p, z] : z_of) {
      if (!(z <= z_max)) z_max = z, worst = p;
    }
    const double threshold = rule.Threshold(compared);
    line["drift_z"] = compared ? json(z_max) : json(nullptr);
    line["drift_threshold"] = compared ? json(threshold) : json(nullptr);
    if (compared == 0) {
      line["message"] = "nothing compared with the baseline (no 95 % intervals in common)";
    } else {
      std::vector<std::string> moved;
      for (const auto& [p, z] : z_of) {
        if (z > threshold) moved.push_back(p->name);
      }
      line["moved"] = Join(moved, ";");
      if (z_max > threshold) {
        line["status"] = "drift";
        const BaselineParameter& p = *worst;
        const double relative = p.baseline != 0.0 ? p.shift / p.baseline : NAN;
        std::ostringstream message;
        message << "drifted from the baseline: " << p.name << " "
                << (std::isfinite(relative)
                        ? (relative >= 0 ? "+" : "") + DisplayNumber(100.0 * relative) + " %"
                        : std::string("moved"))
                << " (z = " << DisplayNumber(z_max) << " > " << DisplayNumber(threshold)
                << ", the rule's false-alarm rate " << DisplayNumber(rule.alpha) << ")";
        line["message"] = message.str();
      }
    }
  }
  return line;
}

json FleetErrorResult(const FleetRow& row, const std::string& message, double wall_time_s) {
  return {{"id", row.id},
          {"drive", row.drive},
          {"date", row.date},
          {"status", "error"},
          {"message", message},
          {"warnings", ""},
          {"effects", ""},
          {"moved", ""},
          {"report", ""},
          {"J", nullptr},
          {"B", nullptr},
          {"nrmse", nullptr},
          {"drift_z", nullptr},
          {"drift_threshold", nullptr},
          {"wall_time_s", wall_time_s}};
}

std::string FleetReportPath(const std::string& out_dir, const std::string& id) {
  return (fs::path(out_dir) / (id + ".json")).string();
}
std::string FleetRowPath(const std::string& out_dir, const std::string& id) {
  return (fs::path(out_dir) / "rows" / (id + ".json")).string();
}

void PrepareFleetFolder(const std::string& out_dir) {
  for (const fs::path& folder : {fs::path(out_dir), fs::path(out_dir) / "rows"}) {
    std::error_code error;
    fs::create_directories(folder, error);
    if (error || !fs::is_directory(folder)) {
      throw InputError("--out " + out_dir + ": cannot create folder '" + folder.string() +
                       "': " + (error ? error.message() : std::string("not a folder")));
    }
  }
  CheckWritable(FleetRowPath(out_dir, "check"));
}

void StoreFleetRow(const std::string& out_dir, const std::string& id, const std::string& key,
                   const json& result) {
  WriteFileAtomically(FleetRowPath(out_dir, id),
                      json{{"key", key}, {"result", result}}.dump() + "\n");
}

std::optional<json> StoredFleetRow(const std::string& out_dir, const std::string& id,
                                   const std::string& key) {
  std::ifstream in(FleetRowPath(out_dir, id));
  if (!in) return std::nullopt;
  const json stored = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!stored.is_object() || stored.value("key", "") != key || !stored.contains("result")) {
    return std::nullopt;
  }
  const json& result = stored["result"];
  // A row that ran needs its report too (a folder cleaned by hand: run it again).
  const std::string report = result.value("report", "");
  if (!report.empty() && !fs::exists(fs::path(out_dir) / report)) return std::nullopt;
  return result;
}

std::string FleetBaseline(const FleetRow& row, const std::string& baseline_dir) {
  if (!row.baseline.empty() || baseline_dir.empty()) return row.baseline;
  const fs::path candidate = fs::path(baseline_dir) / (row.drive + ".json");
  return fs::exists(candidate) ? candidate.string() : std::string();
}

int FleetSummary::ExitCode() const {
  if (error > 0) return kExitFailed;
  if (drift > 0) return kExitGate;
  return kExitOk;
}

std::vector<std::string> FleetColumns(const std::vector<json>& lines) {
  std::vector<std::string> columns = kFixedColumns;
  std::set<std::string> more;
  for (const json& line : lines) {
    for (const auto& [key, value] : line.items()) {
      if (std::find(columns.begin(), columns.end(), key) == columns.end()) more.insert(key);
    }
  }
  columns.insert(columns.end() - 2, more.begin(), more.end());  // before wall_time_s, report
  return columns;
}

std::string FleetCsv(const std::vector<json>& lines) {
  const std::vector<std::string> columns = FleetColumns(lines);
  std::string out = Join(columns, ",") + "\n";
  for (const json& line : lines) {
    for (std::size_t k = 0; k < columns.size(); ++k) {
      const auto it = line.find(columns[k]);
      out += (k ? "," : "") + CsvCell(it != line.end() ? *it : json(nullptr));
    }
    out += "\n";
  }
  return out;
}

FleetSummary WriteFleetOutputs(const std::vector<FleetRow>& rows, std::vector<json> lines,
                               const std::string& out_dir, const std::string& baseline_dir,
                               bool store_baselines) {
  FleetSummary summary;
  for (std::size_t k = lines.size(); k < rows.size(); ++k) {
    lines.push_back(FleetErrorResult(rows[k], "did not finish (run the batch again to resume)"));
  }
  if (store_baselines && !baseline_dir.empty()) {
    std::error_code error;
    fs::create_directories(baseline_dir, error);
    std::set<std::string> done;
    for (json& line : lines) {
      const std::string drive = line.value("drive", "");
      const fs::path target = fs::path(baseline_dir) / (drive + ".json");
      if (done.count(drive) || line.value("status", "") != "ok" || !line["drift_z"].is_null() ||
          line.value("report", "").empty() || fs::exists(target)) {
        continue;
      }
      WriteFileAtomically(target.string(),
                          ReadFileText((fs::path(out_dir) / line.value("report", "")).string()));
      done.insert(drive);
      ++summary.baselines_stored;
      std::string message = line.value("message", "");
      line["message"] = message + (message.empty() ? "" : "; ") + "stored as the drive's baseline";
    }
  }
  std::string jsonl;
  for (const json& line : lines) {
    ++summary.rows;
    const std::string status = line.value("status", "");
    if (status == "ok")
      ++summary.ok;
    else if (status == "drift")
      ++summary.drift;
    else
      ++summary.error;
    jsonl += line.dump() + "\n";
  }
  WriteFileAtomically((fs::path(out_dir) / "results.csv").string(), FleetCsv(lines));
  WriteFileAtomically((fs::path(out_dir) / "results.jsonl").string(), jsonl);
  WriteFileAtomically(
      (fs::path(out_dir) / "fleet.html").string(),
      FleetHtml(lines, FleetPageCounts{summary.rows, summary.ok, summary.drift, summary.error}));
  return summary;
}

}  // namespace blmd
