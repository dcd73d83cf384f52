#include "blmd/io/csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string_view>
#include <unordered_set>

#include "blmd/error.h"
#include "blmd/io/files.h"

namespace blmd {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::string Quote(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out = "\"";
  for (std::size_t k = 0; k < s.size() && k < kMax; ++k) {
    const unsigned char c = static_cast<unsigned char>(s[k]);
    if (c < 0x20 || c >= 0x7f) {
      static const char* hex = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > kMax) out += "...";
  return out + "\"";
}

}  // namespace

Trace ReadTraceCsv(const std::string& path, const CsvReadOptions& options) {
  return ParseTraceCsv(ReadFileText(path), path, options);
}

Trace ParseTraceCsv(const std::string& text, const std::string& path,
                    const CsvReadOptions& options) {
  auto fail = [&](long line, long column, const std::string& message) -> void {
    throw InputError(path, line, column, message);
  };
  if (text.empty()) fail(0, 0, "empty file: expected a header row such as 't,u,i,w'");
  if (text.size() >= 3 && static_cast<unsigned char>(text[0]) == 0xEF &&
      static_cast<unsigned char>(text[1]) == 0xBB && static_cast<unsigned char>(text[2]) == 0xBF) {
    fail(1, 1, "file starts with a UTF-8 byte-order mark; save it as plain UTF-8/ASCII");
  }
  if (text.find('\0') != std::string::npos) {
    long line = 1 + static_cast<long>(std::count(text.begin(), text.begin() +
                                      static_cast<long>(text.find('\0')), '\n'));
    fail(line, 0, "binary data (NUL byte): not a CSV text file");
  }

  Trace trace;
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  long line_number = 0;
  std::size_t pos = 0;
  bool have_header = false;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    const bool last_line_unterminated = end == std::string::npos;
    if (last_line_unterminated) end = text.size();
    std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') {
      fail(line_number, static_cast<long>(line.size()),
           "line ends with CR (Windows line endings); convert the file with dos2unix");
    }
    if (!have_header) {
      if (!line.empty() && line.front() == '#') {
        std::string_view comment = line.substr(1);
        trace.comments.emplace_back(Trim(comment));
        continue;
      }
      if (Trim(line).empty()) fail(line_number, 1, "empty line where the header row was expected");
      // Header.
      std::size_t start = 0;
      long column_index = 0;
      std::unordered_set<std::string> seen;
      while (true) {
        ++column_index;
        const std::size_t comma = line.find(',', start);
        std::string_view field =
            Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
        if (field.empty()) fail(line_number, column_index, "empty column name in the header");
        if (field.front() == '"' || field.front() == '\'') {
          fail(line_number, column_index,
               "quoted column name " + Quote(field) + ": write plain names such as t,u,w");
        }
        for (char c : field) {
          if (c == ';' || c == '\t') {
            fail(line_number, column_index,
                 "header " + Quote(line) + " is not comma separated (found '" +
                     std::string(c == ';' ? ";" : "\\t") + "'); use ',' between columns");
          }
        }
        bool numeric = true;
        double ignored = 0.0;
        const auto result = std::from_chars(field.data(), field.data() + field.size(), ignored);
        numeric = result.ec == std::errc() && result.ptr == field.data() + field.size();
        if (numeric) {
          fail(line_number, column_index,
               "header expected but found the number " + Quote(field) +
                   ": the first row must name the columns, e.g. t,u,i,w");
        }
        std::string name(field);
        if (!seen.insert(name).second) {
          fail(line_number, column_index, "duplicate column name '" + name + "'");
        }
        names.push_back(name);
        if (comma == std::string_view::npos) break;
        start = comma + 1;
      }
      columns.assign(names.size(), {});
      have_header = true;
      continue;
    }
    // Data row.
    if (line.empty() && pos >= text.size()) break;  // final newline
    if (line.empty()) fail(line_number, 1, "empty line inside the data");
    if (line.front() == '#') fail(line_number, 1, "comment line inside the data (only before the header)");
    std::size_t start = 0;
    std::size_t column_index = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      std::string_view raw =
          line.substr(start, comma == std::string_view::npos ? line.npos : comma - start);
      if (column_index >= names.size()) {
        fail(line_number, static_cast<long>(column_index + 1),
             "too many fields: the header has " + std::to_string(names.size()) + " columns");
      }
      std::string_view field = Trim(raw);
      const std::string& name = names[column_index];
      if (field.empty()) {
        fail(line_number, static_cast<long>(column_index + 1),
             "column '" + name + "' is empty" +
                 (last_line_unterminated ? " (truncated last line?)" : ""));
      }
      double value = 0.0;
      const char* first = field.data();
      if (*first == '+' && field.size() > 1 && field[1] != '-') ++first;  // "+1", not "+-1"
      const auto result = std::from_chars(first, field.data() + field.size(), value);
      if (result.ec == std::errc::result_out_of_range) {
        fail(line_number, static_cast<long>(column_index + 1),
             "column '" + name + "' value " + Quote(field) + " is out of the double range");
      }
      if (result.ec != std::errc() || result.ptr != field.data() + field.size()) {
        std::string hint;
        if (field.front() == '"') hint = "; quoted fields are not supported";
        fail(line_number, static_cast<long>(column_index + 1),
             "column '" + name + "' is not a number (" + Quote(field) + ")" + hint);
      }
      if (!std::isfinite(value)) {
        fail(line_number, static_cast<long>(column_index + 1),
             "column '" + name + "' is not finite (" + Quote(field) + ")");
      }
      columns[column_index].push_back(value == 0.0 ? 0.0 : value);  // -0 reads as 0
      ++column_index;
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    if (column_index < names.size()) {
      fail(line_number, static_cast<long>(column_index + 1),
           "too few fields: expected " + std::to_string(names.size()) + ", found " +
               std::to_string(column_index) +
               (last_line_unterminated ? " (truncated last line?)" : ""));
    }
  }
  if (!have_header) fail(line_number, 0, "no header row: expected a row such as 't,u,i,w'");
  if (columns.empty() || columns.front().empty()) {
    fail(line_number, 0, "no data rows after the header");
  }
  for (const auto& required : options.required) {
    bool found = false;
    for (const auto& name : names) found = found || name == required;
    if (!found) {
      std::string have;
      for (const auto& name : names) have += (have.empty() ? "" : ",") + name;
      fail(0, 0, "missing required column '" + required + "' (header has: " + have + ")");
    }
  }
  for (std::size_t c = 0; c < names.size(); ++c) trace.Set(names[c], std::move(columns[c]));
  if (!options.time_column.empty() && trace.Has(options.time_column)) {
    const auto& t = trace.Column(options.time_column);
    const long header_line = static_cast<long>(trace.comments.size()) + 1;
    const long column = trace.Find(options.time_column) + 1;
    for (std::size_t k = 1; k < t.size(); ++k) {
      if (!(t[k] > t[k - 1])) {
        fail(header_line + 1 + static_cast<long>(k), column,
             "time '" + options.time_column + "' must strictly increase (" +
                 FormatNumber(t[k]) + (t[k] == t[k - 1] ? " repeats " : " follows ") +
                 FormatNumber(t[k - 1]) + ")");
      }
    }
  }
  return trace;
}

std::string FormatNumber(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string FormatTraceCsv(const Trace& trace) {
  std::string out;
  for (const auto& comment : trace.comments) out += "# " + comment + "\n";
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    out += (c ? "," : "") + trace.names()[c];
  }
  out += "\n";
  char buffer[64];
  out.reserve(out.size() + trace.rows() * trace.num_columns() * 14);
  for (std::size_t r = 0; r < trace.rows(); ++r) {
    for (std::size_t c = 0; c < trace.num_columns(); ++c) {
      if (c) out += ',';
      const double v = trace.Column(c)[r];
      const auto result = std::to_chars(buffer, buffer + sizeof buffer, v == 0.0 ? 0.0 : v);
      out.append(buffer, result.ptr);
    }
    out += '\n';
  }
  return out;
}

void WriteTraceCsv(const Trace& trace, const std::string& path) {
  WriteFileAtomically(path, FormatTraceCsv(trace));
}

}  // namespace blmd
