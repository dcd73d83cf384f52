#include "blmd/io/surface_file.h"

#include <map>
#include <sstream>

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
      } else if (!header_seen && line.rfind("#", 0) == 0) {
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
        throw InputError(path + ": shard of " + std::to_string(part.count) + " parts, others have " +
                         std::to_string(count));
      }
      if (part.metadata != metadata || part.header != header) {
        throw InputError(path + ": belongs to another sweep (config, trace, observe or grid differ from " +
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
      throw InputError("merge: shard " + std::to_string(k) + "/" + std::to_string(count) + " is missing");
    }
  }
  std::string out = metadata + header + "\n";
  for (const auto& [index, part] : parts) out += part.body;
  return out;
}

}  // namespace blmd
