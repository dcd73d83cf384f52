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

SurfaceFile ReadSurfaceCsv(const std::string& path) {
  return ParseSurfaceCsv(ReadFileText(path), path);
}

SurfaceFile ParseSurfaceCsv(const std::string& text, const std::string& path) {
  SurfaceFile file;
  std::istringstream in(text);
  std::string line;
  long line_number = 0;
  bool header_seen = false, observe_seen = false;
  std::vector<std::string> expected_header;
  std::size_t first = 0, last = 0, row = 0;  // the file's slice [first, last) of the grid
  std::vector<long> columns;
  auto fail = [&](long column, const std::string& message) -> InputError {
    return InputError(path, line_number, column, message);
  };
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!header_seen && !line.empty() && line[0] == '#') {
      std::string content = line.substr(1);
      if (!content.empty() && content[0] == ' ') content.erase(0, 1);
      auto value_of = [&](const std::string& key) -> const char* {
        return content.rfind(key, 0) == 0 ? content.c_str() + key.size() : nullptr;
      };
      if (const char* spec = value_of("shard: ")) {
        const std::string s = spec;
        const auto slash = s.find('/');
        double k = 0, n = 0;
        if (slash == std::string::npos || !ParseDecimal(s.substr(0, slash), &k) ||
            !ParseDecimal(s.substr(slash + 1), &n) || k != std::floor(k) || n != std::floor(n) ||
            k < 1 || n < 1 || k > n || n > 1e9) {
          throw fail(1, "bad shard line '" + line + "' (expected '# shard: K/N' with 1 <= K <= N)");
        }
        file.metadata.shard_index = static_cast<int>(k);
        file.metadata.shard_count = static_cast<int>(n);
        continue;
      }
      if (const char* model = value_of("model: ")) file.model = model;
      if (const char* names = value_of("observe: ")) {
        if (observe_seen) throw fail(1, "a second '# observe:' line");
        observe_seen = true;
        std::vector<long> unused;
        file.observe = SplitFields(names, &unused);
        for (const auto& name : file.observe) {
          if (name.empty())
            throw fail(1, "bad observe line '" + line + "' (expected '# observe: i[,w...]')");
        }
      }
      if (const char* spec = value_of("grid: ")) {
        if (file.axes.size() == 2)
          throw fail(1, "a third '# grid:' line (a surface has 1 or 2 axes)");
        GridAxis axis;
        try {
          axis = ParseGridAxis(spec);
        } catch (const InputError& error) {
          std::string message = error.what();
          if (message.rfind("--grid ", 0) == 0) message.erase(0, 7);
          throw fail(1, "bad grid line: " + message);
        }
        for (const auto& other : file.axes) {
          if (other.name == axis.name) throw fail(1, "grid axis '" + axis.name + "' given twice");
        }
        file.axes.push_back(axis);
      }
      file.metadata.lines.push_back(content);
      continue;
    }
    if (!header_seen) {
      header_seen = true;
      if (file.axes.empty()) {
        throw fail(0, "not a blmd-surface CSV: no '# grid: P=LO:HI:N' line before the header");
      }
      if (!observe_seen)
        throw fail(0, "not a blmd-surface CSV: no '# observe:' line before the header");
      std::string expected;
      for (const auto& axis : file.axes) expected += axis.name + ",";
      for (const auto& column : file.observe) expected += "mse_" + column + ",";
      expected += "cost";
      if (line != expected) {
        throw fail(1, "header '" + line +
                          "' does not match the grid and observe lines (expected '" + expected +
                          "')");
      }
      expected_header = SplitFields(expected, &columns);
      file.grid_size = 1;
      for (const auto& axis : file.axes) file.grid_size *= static_cast<std::size_t>(axis.count);
      std::tie(first, last) =
          ShardRange(file.grid_size, file.metadata.shard_index, file.metadata.shard_count);
      row = first;
      continue;
    }
    // A data row: the next grid point of the slice.
    if (line.empty()) throw fail(0, "empty line");
    if (row >= last) {
      throw fail(1, "more rows than the " +
                        std::string(file.is_shard() ? "shard's slice of the " : "") +
                        "grid has points (" + std::to_string(last - first) + ")");
    }
    const std::vector<std::string> fields = SplitFields(line, &columns);
    if (fields.size() != expected_header.size()) {
      throw fail(0, std::to_string(fields.size()) + " fields, the header has " +
                        std::to_string(expected_header.size()));
    }
    SurfacePoint point;
    std::size_t index = row;
    std::vector<int> position(file.axes.size());
    for (std::size_t a = file.axes.size(); a-- > 0;) {
      const std::size_t n = static_cast<std::size_t>(file.axes[a].count);
      position[a] = static_cast<int>(index % n);
      index /= n;
    }
    for (std::size_t a = 0; a < file.axes.size(); ++a) {
      const GridAxis& axis = file.axes[a];
      const double expected = axis.Value(position[a]);
      double value = 0.0;
      if (!ParseDecimal(fields[a], &value)) {
        throw fail(columns[a],
                   "column '" + axis.name + "' is not a finite number (\"" + fields[a] + "\")");
      }
      const double scale = std::max({std::abs(expected), std::abs(axis.low), std::abs(axis.high)});
      if (!(std::abs(value - expected) <= 1e-9 * scale)) {
        throw fail(columns[a], axis.name + " = " + fields[a] + " is not the next grid point (row " +
                                   std::to_string(row - first + 1) + " of the " +
                                   (file.is_shard() ? "shard" : "grid") + " should have " +
                                   axis.name + " = " + FormatNumber(expected) + ")");
      }
      point.coordinates.push_back(expected);
    }
    const std::size_t cost_field = fields.size() - 1;
    const std::string& cost_text = fields[cost_field];
    double cost = 0.0;
    if (cost_text == "inf") {
      point.evaluation.ok = false;
      point.evaluation.cost = std::numeric_limits<double>::infinity();
      point.evaluation.reason = "failed (cost inf in " + path + ")";
    } else if (ParseDecimal(cost_text, &cost) && cost >= 0.0) {
      point.evaluation.ok = true;
      point.evaluation.cost = cost;
    } else {
      throw fail(columns[cost_field],
                 "column 'cost' is not a number >= 0 or 'inf' (\"" + cost_text + "\")");
    }
    for (std::size_t f = file.axes.size(); f < cost_field; ++f) {
      double mse = 0.0;
      const bool empty = fields[f].empty();
      if (point.evaluation.ok ? !(ParseDecimal(fields[f], &mse) && mse >= 0.0)
                              : !(empty || ParseDecimal(fields[f], &mse))) {
        throw fail(columns[f], "column '" + expected_header[f] + "' is not a number >= 0" +
                                   (point.evaluation.ok ? "" : " or empty") + " (\"" + fields[f] +
                                   "\")");
      }
      if (point.evaluation.ok) point.evaluation.mse.push_back(mse);
    }
    file.points.push_back(std::move(point));
    file.grid_indices.push_back(row);
    ++row;
  }
  if (!header_seen) {
    throw InputError(path + ": not a blmd-surface CSV (no header row" +
                     std::string(file.axes.empty() ? ", no '# grid:' line" : "") + ")");
  }
  if (row < last) {
    throw InputError(path, line_number, 0,
                     "the file ends after " + std::to_string(row - first) + " of the " +
                         std::to_string(last - first) + " points of the " +
                         (file.is_shard() ? "shard " + std::to_string(file.metadata.shard_index) +
                                                "/" + std::to_string(file.metadata.shard_count)
                                          : std::string("grid")) +
                         " (truncated?)");
  }
  return file;
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
