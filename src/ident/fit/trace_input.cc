#include "blmd/ident/fit/trace_input.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"

namespace blmd {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

std::string SelectFormatError(const std::string& text) {
  return "--select '" + text +
         "': expected NAME=VALUE[,VALUE...] or NAME=LO:HI (LO or HI may be left out)";
}

// A finite decimal number, the whole of `field`.
double SelectNumber(const std::string& text, const std::string& field) {
  const char* begin = field.data();
  const char* end = field.data() + field.size();
  if (begin != end && *begin == '+') ++begin;
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (field.empty() || begin == end || ec != std::errc() || ptr != end || !std::isfinite(value)) {
    throw InputError("--select " + text + ": '" + field + "' is not a finite number");
  }
  return value;
}

// Lowest and highest value of a column, for "no row matches" messages.
std::string Span(const std::vector<double>& values) {
  const auto [low, high] = std::minmax_element(values.begin(), values.end());
  return DisplayNumber(*low) + " ... " + DisplayNumber(*high);
}

}  // namespace

bool RowSelection::Matches(double value) const {
  for (const auto& [low, high] : ranges) {
    if (value >= low && value <= high) return true;
  }
  return false;
}

RowSelection ParseRowSelection(const std::string& text) {
  const std::size_t equals = text.find('=');
  if (equals == std::string::npos || equals == 0 || equals + 1 == text.size()) {
    throw InputError(SelectFormatError(text));
  }
  RowSelection selection;
  selection.column = text.substr(0, equals);
  selection.text = text;
  const std::string spec = text.substr(equals + 1);
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = spec.find(',', start);
    const std::string item =
        spec.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (item.empty()) throw InputError(SelectFormatError(text));
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos) {
      const double value = SelectNumber(text, item);
      selection.ranges.emplace_back(value, value);
    } else {
      const std::string low_text = item.substr(0, colon), high_text = item.substr(colon + 1);
      if ((low_text.empty() && high_text.empty()) || high_text.find(':') != std::string::npos) {
        throw InputError(SelectFormatError(text));
      }
      const double low = low_text.empty() ? -kInfinity : SelectNumber(text, low_text);
      const double high = high_text.empty() ? kInfinity : SelectNumber(text, high_text);
      if (low > high) {
        throw InputError("--select " + text + ": the range " + item +
                         " is inverted (LO must not exceed HI)");
      }
      selection.ranges.emplace_back(low, high);
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return selection;
}

std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& x) {
  const std::size_t n = x.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  d[0] = (x[1] - x[0]) / (t[1] - t[0]);
  d[n - 1] = (x[n - 1] - x[n - 2]) / (t[n - 1] - t[n - 2]);
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (x[k + 1] - x[k - 1]) / (t[k + 1] - t[k - 1]);
  return d;
}

namespace {

// The header names of the columns a fit reads (the CSV reader reads them strictly).
std::vector<std::string> UsedHeaders(const TraceInputOptions& options) {
  auto header_of = [&](const std::string& name) {
    const auto mapped = options.columns.find(name);
    return mapped == options.columns.end() ? name : mapped->second;
  };
  std::vector<std::string> used = {"t", options.input, "open"};
  used.insert(used.end(), options.required.begin(), options.required.end());
  for (const auto& [target, source] : options.derive) used.push_back(source);
  for (const auto& selection : options.select) used.push_back(selection.column);
  if (!options.split.empty()) used.push_back(options.split);
  for (const auto& [name, factor] : options.scales) used.push_back(name);
  if (options.initial_from_trace) used.insert(used.end(), {"i", "w", "theta"});
  std::vector<std::string> headers;
  headers.reserve(used.size());
  for (const auto& name : used) headers.push_back(header_of(name));
  return headers;
}

}  // namespace

std::vector<FitTrace> LoadFitTraces(const std::string& path, const TraceInputOptions& options,
                                    const InitialState& default_initial) {
  CsvReadOptions csv;
  // The reader checks no time column: PrepareFitTraces checks t, and merges the rows that
  // repeat a stamp (--duplicate-time), per experiment after --select and --split (a logger
  // may restart its clock per run, and the rows of one instant may differ in a column that
  // selects or splits). The trace's rows are then the file's lines, for every message.
  csv.time_column = "";
  csv.delimiter = options.delimiter;
  csv.names = options.names;
  csv.sample_rate = options.sample_rate;
  // The columns this fit reads are read strictly; any other may hold text (a timestamp, a
  // state name) or empty cells, and is then left out (docs/trace-format.md).
  csv.strict_columns = UsedHeaders(options);
  std::string sha256;
  Trace trace = ReadTraceCsv(path, csv, &sha256);
  return PrepareFitTraces(std::move(trace), path, sha256, options, default_initial);
}

namespace {

// Where the rows and columns of a trace are in its file, for error messages.
struct TraceFile {
  const std::string& path;
  const TraceInputOptions& options;
  long first_line = 0;  // line of row 0: after the comments and the header
  // The file's field (1-based) holding a column, before mapping added columns at the end.
  std::map<std::string, long> fields;

  long LineOf(std::size_t row) const { return first_line + static_cast<long>(row); }
  // The field of a standard column (through --column), 0 when the file has none.
  long FieldOf(const std::string& name) const {
    const auto mapped = options.columns.find(name);
    const auto found = fields.find(mapped == options.columns.end() ? name : mapped->second);
    return found == fields.end() ? 0 : found->second;
  }
};

TraceFile LocateTrace(const Trace& trace, const std::string& path,
                      const TraceInputOptions& options) {
  // Line of row k: comments, the header (none with --no-header), then k + 1.
  TraceFile file{path,
                 options,
                 static_cast<long>(trace.comments.size()) + (options.names.empty() ? 2 : 1),
                 {}};
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    file.fields[trace.names()[c]] = static_cast<long>(c + 1);
  }
  return file;
}

// The columns a fit reads must hold finite numbers (the CSV reader has checked a file's).
void CheckFinite(const Trace& trace, const TraceFile& file) {
  for (const auto& header : UsedHeaders(file.options)) {
    const int c = trace.Find(header);
    if (c < 0) continue;
    const auto& column = trace.Column(static_cast<std::size_t>(c));
    for (std::size_t k = 0; k < column.size(); ++k) {
      if (!std::isfinite(column[k])) {
        throw InputError(
            file.path, file.LineOf(k), c + 1,
            "column '" + header + "' is not a finite number (" + DisplayNumber(column[k]) + ")");
      }
    }
  }
}

// Column mapping (header -> standard name), then scaling.
void MapAndScaleColumns(Trace& trace, const std::string& path, const TraceInputOptions& options) {
  for (const auto& [standard, header] : options.columns) {
    if (!trace.Has(header)) {
      throw InputError(path + ": --column " + standard + "=" + header + ": no column '" + header +
                       "' (header has: " + HeaderSummary(trace.names()) + ")");
    }
    if (standard != header && trace.Has(standard)) {
      trace.Rename(standard, standard + "_original");
    }
    if (standard != header) trace.Set(standard, trace.Column(header));
  }
  for (const auto& [name, factor] : options.scales) {
    if (!trace.Has(name))
      throw InputError(path + ": --scale " + name + ": no column '" + name + "'");
    for (double& v : trace.Column(name)) {
      v *= factor;
      if (v == 0.0) v = 0.0;  // never -0 (as the reader promises): 0 times a negative factor
    }
  }
}

// t, u, the sources of --derive and the columns of --select and --split must exist.
void CheckNamedColumns(const Trace& trace, const std::string& path,
                       const TraceInputOptions& options) {
  std::vector<std::string> required = {"t", options.input};
  for (const auto& [target, source] : options.derive) required.push_back(source);
  for (const auto& name : required) {
    if (!trace.Has(name)) {
      throw InputError(path + ": missing required column '" + name +
                       "' (header has: " + HeaderSummary(trace.names()) +
                       "; map another header with --column " + name + "=HEADER)");
    }
  }
  for (const auto& selection : options.select) {
    if (!trace.Has(selection.column)) {
      throw InputError(path + ": --select " + selection.text + ": no column '" + selection.column +
                       "' (header has: " + HeaderSummary(trace.names()) + ")");
    }
  }
  if (!options.split.empty() && !trace.Has(options.split)) {
    throw InputError(path + ": --split " + options.split + ": no column '" + options.split +
                     "' (header has: " + HeaderSummary(trace.names()) + ")");
  }
}

// The rows every --select keeps; none is an error.
std::vector<std::size_t> SelectedRows(const Trace& trace, const std::string& path,
                                      const TraceInputOptions& options) {
  std::vector<std::size_t> kept;
  kept.reserve(trace.rows());
  for (std::size_t k = 0; k < trace.rows(); ++k) {
    bool keep = true;
    for (const auto& selection : options.select) {
      keep = keep && selection.Matches(trace.Column(selection.column)[k]);
    }
    if (keep) kept.push_back(k);
  }
  if (kept.empty()) {
    std::string what;
    for (const auto& selection : options.select) {
      what += std::string(what.empty() ? "" : ", ") + "'" + selection.column + "' holds " +
              Span(trace.Column(selection.column));
    }
    std::string flags;
    for (const auto& selection : options.select) flags += " --select " + selection.text;
    throw InputError(path + ": no row matches" + flags + " (" + what + ")");
  }
  return kept;
}

// One experiment: a block of consecutive rows.
struct Block {
  std::size_t begin = 0, end = 0;  // rows [begin, end)
  double value = 0.0;              // of the split column
};

// The experiments: blocks of consecutive kept rows, cut where the split column changes. A block
// the selection breaks, or a split value that comes back, is an error.
std::vector<Block> CutIntoBlocks(const Trace& trace, const TraceFile& file,
                                 const std::vector<std::size_t>& kept) {
  const TraceInputOptions& options = file.options;
  std::vector<Block> blocks;
  const std::vector<double>* split_values =
      options.split.empty() ? nullptr : &trace.Column(options.split);
  for (std::size_t row : kept) {
    const double value = split_values ? (*split_values)[row] : 0.0;
    if (!blocks.empty() && value == blocks.back().value) {
      if (row == blocks.back().end) {
        ++blocks.back().end;
        continue;
      }
      // The same experiment resumes after rows the selection dropped.
      const std::string part = split_values
                                   ? "the rows with " + options.split + " = " + DisplayNumber(value)
                                   : "the rows kept";
      throw InputError(file.path, file.LineOf(row), 1,
                       "--select keeps " + part + " in more than one block (line " +
                           std::to_string(file.LineOf(blocks.back().end - 1)) + ", then line " +
                           std::to_string(file.LineOf(row)) +
                           "): one experiment must be an unbroken block of rows; narrow the "
                           "selection" +
                           (split_values ? "" : ", or cut the file with --split COLUMN"));
    }
    if (split_values) {
      for (const Block& earlier : blocks) {
        if (earlier.value == value) {
          throw InputError(file.path, file.LineOf(row), file.FieldOf(options.split),
                           "--split " + options.split + ": " + options.split + " = " +
                               DisplayNumber(value) + " appears again (its first block is lines " +
                               std::to_string(file.LineOf(earlier.begin)) + "-" +
                               std::to_string(file.LineOf(earlier.end - 1)) +
                               "); the rows of one experiment must be an unbroken block");
        }
      }
    }
    blocks.push_back({row, row + 1, value});
  }
  return blocks;
}

// One experiment's samples (repeated time stamps merged, resampled), its name, and the rows
// of the trace they come from, for messages.
struct Samples {
  Trace part;
  std::string name;
  std::size_t first_row = 0, last_row = 0;  // the trace rows the samples span
  // The trace row of each sample (the first of its instant) when rows were merged; empty:
  // sample k is row first_row + k.
  std::vector<std::size_t> rows;
  bool cut = false;  // one of the parts of an experiment cut at a gap (--resample)

  std::size_t RowOf(std::size_t k) const { return rows.empty() ? first_row + k : rows[k]; }
};

// The time column's name in the file, for messages.
std::string TimeHeader(const TraceInputOptions& options) {
  const auto mapped = options.columns.find("t");
  return mapped == options.columns.end() ? "t" : mapped->second;
}

// The rows of `block`, t strictly increasing, rows that repeat the previous row's time stamp
// merged as --duplicate-time says: the first row of the instant kept (kFirst), every column
// averaged over the instant's rows (kMean, the running mean the CSV reader used), or an error
// that names the flag (kError). `whole`: the block is every row of `trace`, which is moved
// when no row repeats.
Samples ExperimentSamples(Trace& trace, const TraceFile& file, const Block& block,
                          const std::string& name, bool whole) {
  const TraceInputOptions& options = file.options;
  const auto& t = trace.Column("t");
  std::vector<std::size_t> starts;  // the first row of each instant
  starts.reserve(block.end - block.begin);
  for (std::size_t k = block.begin; k < block.end; ++k) {
    if (k > block.begin && !(t[k] > t[k - 1])) {
      const bool repeat = t[k] == t[k - 1];
      if (repeat && options.duplicate_time != DuplicateTime::kError) continue;
      const std::string& split = options.split;
      throw InputError(
          file.path, file.LineOf(k), file.FieldOf("t"),
          "time '" + TimeHeader(options) + "' must strictly increase (" + DisplayNumber(t[k]) +
              (repeat ? " repeats " + DisplayNumber(t[k - 1]) + " of line " +
                            std::to_string(file.LineOf(k - 1))
                      : " follows " + DisplayNumber(t[k - 1])) +
              ")" +
              (!split.empty() ? " within " + split + " = " + DisplayNumber(block.value) : "") +
              (repeat ? "; for several rows logged at one instant use --duplicate-time first|mean"
                      : ""));
    }
    starts.push_back(k);
  }
  Samples samples;
  samples.name = name;
  samples.first_row = block.begin;
  samples.last_row = block.end - 1;
  if (starts.size() == block.end - block.begin) {
    // Without --select or --split the block is the whole trace: it moves once.
    if (whole) {
      samples.part = std::move(trace);
    } else {
      samples.part.comments = trace.comments;
      for (std::size_t c = 0; c < trace.num_columns(); ++c) {
        const auto& column = trace.Column(c);
        samples.part.Append(trace.names()[c],
                            std::vector<double>(column.begin() + static_cast<long>(block.begin),
                                                column.begin() + static_cast<long>(block.end)));
      }
    }
    return samples;
  }
  samples.rows = starts;
  samples.part.comments = trace.comments;
  const bool mean = options.duplicate_time == DuplicateTime::kMean;
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    const auto& column = trace.Column(c);
    std::vector<double> values;
    values.reserve(starts.size());
    for (std::size_t g = 0; g < starts.size(); ++g) {
      const std::size_t end = g + 1 < starts.size() ? starts[g + 1] : block.end;
      double value = column[starts[g]];
      for (std::size_t k = starts[g] + 1; mean && k < end; ++k) {
        value += (column[k] - value) / static_cast<double>(k - starts[g] + 1);
      }
      values.push_back(value == 0.0 ? 0.0 : value);  // never -0
    }
    samples.part.Append(trace.names()[c], std::move(values));
  }
  const std::size_t merged = block.end - block.begin - starts.size();
  if (merged > 0) {
    samples.part.comments.push_back("read with --duplicate-time " +
                                    std::string(mean ? "mean" : "first") + ": " +
                                    std::to_string(merged) + " repeated-time rows merged");
  }
  return samples;
}

// --resample: the samples linearly interpolated onto t0 + k step (k = 0, 1, ... up to the
// last time stamp; `open`, a switch, is held from the sample at or before), the experiment
// cut into parts where a recorded step exceeds kResampleGapSteps grid steps (no samples are
// made up across a gap). As recorded without --resample.
std::vector<Samples> Resample(Samples samples, const TraceFile& file) {
  const TraceInputOptions& options = file.options;
  std::vector<Samples> parts;
  const Trace& part = samples.part;
  const auto& t = part.Column("t");
  const std::size_t n = t.size();
  if ((!options.resample_median && !(options.resample_step > 0.0)) || n < 2) {
    parts.push_back(std::move(samples));
    return parts;
  }
  std::vector<double> steps(n - 1);
  for (std::size_t k = 1; k < n; ++k) steps[k - 1] = t[k] - t[k - 1];
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double step = options.resample_median ? median : options.resample_step;
  const std::string step_text =
      options.resample_median ? "auto (" + FormatSignificant(step, 6) + " s)" : DisplayNumber(step);
  if (median > kResampleGapSteps * step) {
    throw InputError(samples.name + ": --resample " + step_text + " is less than 1/" +
                     FormatSignificant(kResampleGapSteps, 6) + " of the median step, " +
                     FormatSignificant(median, 6) + " s: every recorded step would be a gap; " +
                     "choose a step near the median step (--resample auto)");
  }
  // The parts [first, last] of the samples, cut at the gaps, and the grid points of each.
  // (As no step within a part exceeds kResampleGapSteps grid steps, a part has at most that
  // many grid points per sample.)
  std::vector<std::pair<std::size_t, std::size_t>> ranges;
  std::vector<std::size_t> points;
  std::size_t first = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (k + 1 < n && !(steps[k] > kResampleGapSteps * step)) continue;
    ranges.emplace_back(first, k);
    // 1e-9: a span that is a whole number of steps but for rounding keeps its last point.
    points.push_back(static_cast<std::size_t>(std::floor((t[k] - t[first]) / step + 1e-9)) + 1);
    first = k + 1;
  }
  for (std::size_t r = 0; r < ranges.size(); ++r) {
    const auto [a, b] = ranges[r];
    const std::size_t m = points[r];
    Samples out;
    out.first_row = samples.first_row;  // refined below when the record is cut
    out.last_row = samples.last_row;
    out.cut = ranges.size() > 1;
    out.name = samples.name;
    if (out.cut) {
      out.name += "[t=" + DisplayNumber(t[a]) + ":" + DisplayNumber(t[b]) + "]";
      out.first_row = samples.RowOf(a);
      out.last_row = b + 1 < n ? samples.RowOf(b + 1) - 1 : samples.last_row;
    }
    std::vector<double> grid(m);
    for (std::size_t k = 0; k < m; ++k)
      grid[k] = std::min(t[a] + static_cast<double>(k) * step, t[b]);
    out.part.comments = part.comments;
    out.part.comments.push_back("resampled with --resample " + step_text + ": " +
                                std::to_string(m) + " samples from " + std::to_string(b - a + 1) +
                                " (linear interpolation)");
    for (std::size_t c = 0; c < part.num_columns(); ++c) {
      const std::string& column_name = part.names()[c];
      if (column_name == "t") {
        out.part.Append("t", grid);
        continue;
      }
      const auto& x = part.Column(c);
      const bool hold = column_name == "open";
      std::vector<double> y(m);
      std::size_t j = a;
      for (std::size_t k = 0; k < m; ++k) {
        while (j + 1 < b && t[j + 1] <= grid[k]) ++j;
        if (a == b) {
          y[k] = x[a];
          continue;
        }
        const double frac = std::clamp((grid[k] - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0);
        const double value =
            hold ? (frac >= 1.0 ? x[j + 1] : x[j]) : x[j] + frac * (x[j + 1] - x[j]);
        y[k] = value == 0.0 ? 0.0 : value;
      }
      out.part.Append(column_name, std::move(y));
    }
    parts.push_back(std::move(out));
  }
  return parts;
}

// After --derive: the observed columns must exist and a fit needs at least 3 samples.
void CheckFitColumns(const Samples& samples, const TraceFile& file, bool by_rows) {
  const Trace& part = samples.part;
  const std::string& name = samples.name;
  const std::string& path = file.path;
  for (const auto& required_name : file.options.required) {
    if (!part.Has(required_name)) {
      // A record of the angle alone (an encoder, no tachometer) is common: the two ways to
      // fit it are named where they apply.
      std::string other;
      if (required_name == "w" && part.Has("theta")) {
        other =
            "; or, with only the angle logged, fit it (--observe theta) or the speed derived "
            "from it (--derive w=theta)";
      } else if (required_name == "theta" && part.Has("w")) {
        other = "; or fit the speed alone (--observe w)";
      }
      throw InputError(path + ": missing observed column '" + required_name + "' (header has: " +
                       HeaderSummary(part.names()) + "; map another header with --column " +
                       required_name + "=HEADER" + other + ")");
    }
  }
  if (part.rows() < 3) {
    const std::string count =
        std::to_string(part.rows()) + " sample" + (part.rows() == 1 ? "" : "s");
    if (!by_rows && !samples.cut) {
      throw InputError(path + ": " + count + " only: a fit needs at least 3");
    }
    const long first = file.LineOf(samples.first_row), last = file.LineOf(samples.last_row);
    throw InputError(
        path, first, 0,
        name.substr(path.size()) + " has " + count + " only (line" +
            (first == last ? " " + std::to_string(first)
                           : "s " + std::to_string(first) + "-" + std::to_string(last)) +
            "): a fit needs at least 3 per experiment");
  }
}

// FILE, FILE[COLUMN=VALUE] with --split, FILE[SELECTION] with --select alone.
std::string ExperimentName(const std::string& path, const TraceInputOptions& options,
                           const Block& block) {
  std::string name = path;
  if (!options.split.empty()) {
    name += "[" + options.split + "=" + DisplayNumber(block.value) + "]";
  } else if (!options.select.empty()) {
    std::string selection_name;
    for (const auto& selection : options.select) {
      selection_name += (selection_name.empty() ? "" : ",") + selection.text;
    }
    name += "[" + selection_name + "]";
  }
  return name;
}

InitialState InitialStateOf(const Trace& part, const TraceInputOptions& options,
                            const InitialState& default_initial) {
  InitialState initial = default_initial;
  if (options.initial_from_trace) {
    if (part.Has("w")) initial.w = part.Column("w").front();
    if (part.Has("theta")) initial.theta = part.Column("theta").front();
    if (part.Has("i")) initial.i = part.Column("i").front();
  }
  return initial;
}

}  // namespace

std::vector<FitTrace> PrepareFitTraces(Trace trace, const std::string& path,
                                       const std::string& sha256, const TraceInputOptions& options,
                                       const InitialState& default_initial) {
  const bool by_rows = !options.select.empty() || !options.split.empty();
  const TraceFile file = LocateTrace(trace, path, options);
  CheckFinite(trace, file);
  MapAndScaleColumns(trace, path, options);
  CheckNamedColumns(trace, path, options);
  const std::vector<Block> blocks = CutIntoBlocks(trace, file, SelectedRows(trace, path, options));

  std::vector<FitTrace> experiments;
  experiments.reserve(blocks.size());
  for (const Block& block : blocks) {
    // Without --select or --split there is exactly one block: the trace moves once (unless
    // rows are merged).
    Samples samples = ExperimentSamples(trace, file, block, ExperimentName(path, options, block),
                                        !by_rows);  // NOLINT(bugprone-use-after-move)
    for (Samples& resampled : Resample(std::move(samples), file)) {
      Trace& part = resampled.part;
      for (const auto& [target, source] : options.derive) {
        part.Set(target, Differentiate(part.Column("t"), part.Column(source)));
      }
      CheckFitColumns(resampled, file, by_rows);
      const InitialState initial = InitialStateOf(part, options, default_initial);
      FitTrace fit = RecordedFitTrace(std::move(part), initial, resampled.name, options.input);
      fit.sha256 = sha256;
      experiments.push_back(std::move(fit));
    }
  }
  return experiments;
}

FitTrace RecordedFitTrace(Trace trace, const InitialState& initial, const std::string& path,
                          const std::string& input) {
  FitTrace fit;
  fit.path = path;
  fit.input.kind = InputSignal::Kind::kRecorded;
  fit.input.times = trace.Column("t");
  fit.input.values = trace.Column(input);
  if (trace.Has("open")) fit.input.open = trace.Column("open");
  fit.initial = initial;
  fit.trace = std::move(trace);
  return fit;
}

FitTrace LoadFitTrace(const std::string& path, const TraceInputOptions& options,
                      const InitialState& default_initial) {
  std::vector<FitTrace> experiments = LoadFitTraces(path, options, default_initial);
  if (experiments.size() != 1) {
    throw InputError(path + ": --split " + options.split + " gives " +
                     std::to_string(experiments.size()) +
                     " experiments where one trace is expected");
  }
  return std::move(experiments.front());
}

}  // namespace blmd
