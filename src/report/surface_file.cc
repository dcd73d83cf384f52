#include "blmd/report/surface_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"

namespace blmd {

std::string FormatSurfaceCsv(const SurfaceMetadata& metadata, const std::vector<GridAxis>& axes,
                             const std::vector<std::string>& observe,
                             const std::vector<SurfacePoint>& points) {
  std::string out;
  for (const auto& line : metadata.lines) out += "# " + line + "\n";
  if (metadata.shard_count > 1) {
    out += "# shard: " + std::to_string(metadata.shard_index) + "/" +
           std::to_string(metadata.shard_count) + "\n";
  }
  for (const auto& axis : axes) out += axis.name + ",";
  for (const auto& column : observe) out += "mse_" + column + ",";
  out += "cost\n";
  for (const auto& point : points) {
    for (double c : point.coordinates) out += FormatNumber(c) + ",";
    for (std::size_t c = 0; c < observe.size(); ++c) {
      if (point.evaluation.ok) out += FormatNumber(point.evaluation.mse[c]);
      out += ",";
    }
    out += point.evaluation.ok ? FormatNumber(point.evaluation.cost) : std::string("inf");
    out += "\n";
  }
  return out;
}

namespace {

// Strict decimal number (what FormatNumber writes); false on anything else, "inf"/"nan" too.
bool ParseDecimal(const std::string& text, double* value) {
  if (text.empty()) return false;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (*first == '+') ++first;
  const auto result = std::from_chars(first, last, *value);
  return result.ec == std::errc() && result.ptr == last && std::isfinite(*value);
}

std::vector<std::string> SplitFields(const std::string& line, std::vector<long>* columns) {
  std::vector<std::string> fields;
  columns->clear();
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    columns->push_back(static_cast<long>(start) + 1);
    fields.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

}  // namespace

namespace {

// Reads a surface CSV line by line: '#' lines up to the header, the header, the data rows.
class SurfaceCsvParser {
 public:
  explicit SurfaceCsvParser(const std::string& path) : path_(path) {}

  void Line(std::string line) {
    ++line_number_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!header_seen_ && !line.empty() && line[0] == '#') {
      CommentLine(line);
    } else if (!header_seen_) {
      HeaderLine(line);
    } else {
      DataRow(line);
    }
  }

  SurfaceFile Finish() {
    if (!header_seen_) {
      throw InputError(path_ + ": not a blmd-surface CSV (no header row" +
                       std::string(file_.axes.empty() ? ", no '# grid:' line" : "") + ")");
    }
    if (row_ < last_) {
      throw InputError(
          path_, line_number_, 0,
          "the file ends after " + std::to_string(row_ - first_) + " of the " +
              std::to_string(last_ - first_) + " points of the " +
              (file_.is_shard() ? "shard " + std::to_string(file_.metadata.shard_index) + "/" +
                                      std::to_string(file_.metadata.shard_count)
                                : std::string("grid")) +
              " (truncated?)");
    }
    return std::move(file_);
  }

 private:
  InputError Fail(long column, const std::string& message) const {
    return InputError(path_, line_number_, column, message);
  }

  // A '#' line before the header: shard, model, observe and grid lines are read; every line
  // but the shard's is kept in the metadata.
  void CommentLine(const std::string& line) {
    std::string content = line.substr(1);
    if (!content.empty() && content[0] == ' ') content.erase(0, 1);
    auto value_of = [&](const std::string& key) -> const char* {
      return content.rfind(key, 0) == 0 ? content.c_str() + key.size() : nullptr;
    };
    if (const char* spec = value_of("shard: ")) {
      ShardLine(line, spec);
      return;
    }
    if (const char* model = value_of("model: ")) file_.model = model;
    if (const char* names = value_of("observe: ")) ObserveLine(line, names);
    if (const char* spec = value_of("grid: ")) GridLine(spec);
    file_.metadata.lines.push_back(content);
  }

  void ShardLine(const std::string& line, const std::string& spec) {
    const auto slash = spec.find('/');
    double k = 0, n = 0;
    if (slash == std::string::npos || !ParseDecimal(spec.substr(0, slash), &k) ||
        !ParseDecimal(spec.substr(slash + 1), &n) || k != std::floor(k) || n != std::floor(n) ||
        k < 1 || n < 1 || k > n || n > 1e9) {
      throw Fail(1, "bad shard line '" + line + "' (expected '# shard: K/N' with 1 <= K <= N)");
    }
    file_.metadata.shard_index = static_cast<int>(k);
    file_.metadata.shard_count = static_cast<int>(n);
  }

  void ObserveLine(const std::string& line, const std::string& names) {
    if (observe_seen_) throw Fail(1, "a second '# observe:' line");
    observe_seen_ = true;
    std::vector<long> unused;
    file_.observe = SplitFields(names, &unused);
    for (const auto& name : file_.observe) {
      if (name.empty())
        throw Fail(1, "bad observe line '" + line + "' (expected '# observe: i[,w...]')");
    }
  }

  void GridLine(const std::string& spec) {
    if (file_.axes.size() == 2) throw Fail(1, "a third '# grid:' line (a surface has 1 or 2 axes)");
    GridAxis axis;
    try {
      axis = ParseGridAxis(spec);
    } catch (const InputError& error) {
      std::string message = error.what();
      if (message.rfind("--grid ", 0) == 0) message.erase(0, 7);
      throw Fail(1, "bad grid line: " + message);
    }
    for (const auto& other : file_.axes) {
      if (other.name == axis.name) throw Fail(1, "grid axis '" + axis.name + "' given twice");
    }
    file_.axes.push_back(axis);
  }

  // The header must be the one the grid and observe lines give; then the rows expected.
  void HeaderLine(const std::string& line) {
    header_seen_ = true;
    if (file_.axes.empty()) {
      throw Fail(0, "not a blmd-surface CSV: no '# grid: P=LO:HI:N' line before the header");
    }
    if (!observe_seen_)
      throw Fail(0, "not a blmd-surface CSV: no '# observe:' line before the header");
    std::string expected;
    for (const auto& axis : file_.axes) expected += axis.name + ",";
    for (const auto& column : file_.observe) expected += "mse_" + column + ",";
    expected += "cost";
    if (line != expected) {
      throw Fail(1, "header '" + line + "' does not match the grid and observe lines (expected '" +
                        expected + "')");
    }
    expected_header_ = SplitFields(expected, &columns_);
    file_.grid_size = 1;
    for (const auto& axis : file_.axes) file_.grid_size *= static_cast<std::size_t>(axis.count);
    std::tie(first_, last_) =
        ShardRange(file_.grid_size, file_.metadata.shard_index, file_.metadata.shard_count);
    row_ = first_;
  }

  // A data row: the next grid point of the slice.
  void DataRow(const std::string& line) {
    if (line.empty()) throw Fail(0, "empty line");
    if (row_ >= last_) {
      throw Fail(1, "more rows than the " +
                        std::string(file_.is_shard() ? "shard's slice of the " : "") +
                        "grid has points (" + std::to_string(last_ - first_) + ")");
    }
    const std::vector<std::string> fields = SplitFields(line, &columns_);
    if (fields.size() != expected_header_.size()) {
      throw Fail(0, std::to_string(fields.size()) + " fields, the header has " +
                        std::to_string(expected_header_.size()));
    }
    SurfacePoint point;
    point.coordinates = GridCoordinates(fields);
    ReadCost(fields, point.evaluation);
    file_.points.push_back(std::move(point));
    file_.grid_indices.push_back(row_);
    ++row_;
  }

  // The coordinate fields must be the grid values of the row's point (to 1e-9 relative); the
  // exact grid values are kept.
  std::vector<double> GridCoordinates(const std::vector<std::string>& fields) const {
    std::size_t index = row_;
    std::vector<int> position(file_.axes.size());
    for (std::size_t a = file_.axes.size(); a-- > 0;) {
      const std::size_t n = static_cast<std::size_t>(file_.axes[a].count);
      position[a] = static_cast<int>(index % n);
      index /= n;
    }
    std::vector<double> coordinates;
    for (std::size_t a = 0; a < file_.axes.size(); ++a) {
      const GridAxis& axis = file_.axes[a];
      const double expected = axis.Value(position[a]);
      double value = 0.0;
      if (!ParseDecimal(fields[a], &value)) {
        throw Fail(columns_[a],
                   "column '" + axis.name + "' is not a finite number (\"" + fields[a] + "\")");
      }
      const double scale = std::max({std::abs(expected), std::abs(axis.low), std::abs(axis.high)});
      if (!(std::abs(value - expected) <= 1e-9 * scale)) {
        throw Fail(columns_[a], axis.name + " = " + fields[a] +
                                    " is not the next grid point (row " +
                                    std::to_string(row_ - first_ + 1) + " of the " +
                                    (file_.is_shard() ? "shard" : "grid") + " should have " +
                                    axis.name + " = " + FormatNumber(expected) + ")");
      }
      coordinates.push_back(expected);
    }
    return coordinates;
  }

  // The cost ('inf': a failed point) and the mse fields (empty allowed on a failed point).
  void ReadCost(const std::vector<std::string>& fields, Evaluation& evaluation) const {
    const std::size_t cost_field = fields.size() - 1;
    const std::string& cost_text = fields[cost_field];
    double cost = 0.0;
    if (cost_text == "inf") {
      evaluation.ok = false;
      evaluation.cost = std::numeric_limits<double>::infinity();
      evaluation.reason = "failed (cost inf in " + path_ + ")";
    } else if (ParseDecimal(cost_text, &cost) && cost >= 0.0) {
      evaluation.ok = true;
      evaluation.cost = cost;
    } else {
      throw Fail(columns_[cost_field],
                 "column 'cost' is not a number >= 0 or 'inf' (\"" + cost_text + "\")");
    }
    for (std::size_t f = file_.axes.size(); f < cost_field; ++f) {
      double mse = 0.0;
      const bool empty = fields[f].empty();
      if (evaluation.ok ? !(ParseDecimal(fields[f], &mse) && mse >= 0.0)
                        : !(empty || ParseDecimal(fields[f], &mse))) {
        throw Fail(columns_[f], "column '" + expected_header_[f] + "' is not a number >= 0" +
                                    (evaluation.ok ? "" : " or empty") + " (\"" + fields[f] +
                                    "\")");
      }
      if (evaluation.ok) evaluation.mse.push_back(mse);
    }
  }

  const std::string& path_;
  SurfaceFile file_;
  long line_number_ = 0;
  bool header_seen_ = false, observe_seen_ = false;
  std::vector<std::string> expected_header_;
  std::size_t first_ = 0, last_ = 0, row_ = 0;  // the file's slice [first, last) of the grid
  std::vector<long> columns_;                   // 1-based column of each field of a line
};

}  // namespace

SurfaceFile ReadSurfaceCsv(const std::string& path) {
  return ParseSurfaceCsv(ReadFileText(path), path);
}

SurfaceFile ParseSurfaceCsv(const std::string& text, const std::string& path) {
  SurfaceCsvParser parser(path);
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) parser.Line(line);
  return parser.Finish();
}

std::vector<SurfacePoint> SurfaceGridPoints(const SurfaceFile& file) {
  if (!file.is_shard()) return file.points;
  std::vector<SurfacePoint> grid(file.grid_size);
  for (std::size_t index = 0; index < grid.size(); ++index) {
    std::size_t rest = index;
    grid[index].coordinates.resize(file.axes.size());
    for (std::size_t a = file.axes.size(); a-- > 0;) {
      const std::size_t n = static_cast<std::size_t>(file.axes[a].count);
      grid[index].coordinates[a] = file.axes[a].Value(static_cast<int>(rest % n));
      rest /= n;
    }
    grid[index].evaluation.ok = false;
    grid[index].evaluation.cost = std::numeric_limits<double>::quiet_NaN();
    grid[index].evaluation.reason = "not in shard " + std::to_string(file.metadata.shard_index) +
                                    "/" + std::to_string(file.metadata.shard_count);
  }
  for (std::size_t k = 0; k < file.points.size(); ++k) grid[file.grid_indices[k]] = file.points[k];
  return grid;
}

std::string MergeSurfaceParts(const std::vector<std::string>& paths) {
  if (paths.empty()) throw InputError("merge: no parts given");
  struct Part {
    std::string path, metadata, header, body;
    int index = 0, count = 0;
  };
  std::map<int, Part> parts;
  int count = 0;
  std::string metadata, header;
  for (const auto& path : paths) {
    const std::string text = ReadFileText(path);
    Part part;
    part.path = path;
    std::istringstream in(text);
    std::string line;
    long line_number = 0;
    bool header_seen = false;
    while (std::getline(in, line)) {
      ++line_number;
      if (!header_seen && line.rfind("# shard: ", 0) == 0) {
        const std::string spec = line.substr(9);
        const auto slash = spec.find('/');
        try {
          part.index = std::stoi(spec.substr(0, slash));
          part.count = std::stoi(spec.substr(slash + 1));
        } catch (const std::exception&) {
          throw InputError(path, line_number, 1, "bad shard line '" + line + "'");
        }
      } else if (!header_seen && line.rfind('#', 0) == 0) {
        part.metadata += line + "\n";
      } else if (!header_seen) {
        part.header = line;
        header_seen = true;
      } else {
        part.body += line + "\n";
      }
    }
    if (!header_seen) throw InputError(path + ": not a surface CSV (no header row)");
    if (part.count == 0) {
      throw InputError(path + ": not a shard (no '# shard: K/N' line); only shards are merged");
    }
    if (parts.empty()) {
      count = part.count;
      metadata = part.metadata;
      header = part.header;
    } else {
      if (part.count != count) {
        throw InputError(path + ": shard of " + std::to_string(part.count) +
                         " parts, others have " + std::to_string(count));
      }
      if (part.metadata != metadata || part.header != header) {
        throw InputError(path +
                         ": belongs to another sweep (config, trace, observe or grid differ from " +
                         parts.begin()->second.path + ")");
      }
    }
    if (parts.count(part.index)) {
      throw InputError(path + ": shard " + std::to_string(part.index) + " given twice (also " +
                       parts[part.index].path + ")");
    }
    parts[part.index] = part;
  }
  for (int k = 1; k <= count; ++k) {
    if (!parts.count(k)) {
      throw InputError("merge: shard " + std::to_string(k) + "/" + std::to_string(count) +
                       " is missing");
    }
  }
  std::string out = metadata + header + "\n";
  for (const auto& [index, part] : parts) out += part.body;
  return out;
}

}  // namespace blmd
