#include "blmd/io/csv.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
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

std::string Hex(unsigned char c) {
  static const char* hex = "0123456789abcdef";
  return std::string("\\x") + hex[c >> 4] + hex[c & 15];
}

std::string Quote(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out = "\"";
  for (std::size_t k = 0; k < s.size() && k < kMax; ++k) {
    const unsigned char c = static_cast<unsigned char>(s[k]);
    if (c < 0x20 || c >= 0x7f) {
      out += Hex(c);
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > kMax) out += "...";
  return out + "\"";
}

// Offset of the first byte that is not well-formed UTF-8 (npos when all are).
std::size_t InvalidUtf8(std::string_view s) {
  std::size_t k = 0;
  while (k < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[k]);
    int follow = 0;
    unsigned char low = 0x80, high = 0xBF;  // allowed range of the first continuation byte
    if (c < 0x80) {
      ++k;
      continue;
    } else if (c >= 0xC2 && c <= 0xDF) {
      follow = 1;
    } else if (c >= 0xE0 && c <= 0xEF) {
      follow = 2;
      if (c == 0xE0) low = 0xA0;
      if (c == 0xED) high = 0x9F;  // no surrogates
    } else if (c >= 0xF0 && c <= 0xF4) {
      follow = 3;
      if (c == 0xF0) low = 0x90;
      if (c == 0xF4) high = 0x8F;
    } else {
      return k;
    }
    if (k + static_cast<std::size_t>(follow) >= s.size()) return k;
    for (int f = 1; f <= follow; ++f) {
      const unsigned char d = static_cast<unsigned char>(s[k + static_cast<std::size_t>(f)]);
      const unsigned char lo = f == 1 ? low : 0x80, hi = f == 1 ? high : 0xBF;
      if (d < lo || d > hi) return k;
    }
    k += static_cast<std::size_t>(follow) + 1;
  }
  return std::string_view::npos;
}

// Bytes at the start of the input examined for a byte-order mark and binary data.
constexpr std::size_t kSniffBytes = 64 << 10;

// The reader's state machine, fed the file's bytes in pieces (a whole text at once, or a
// file chunk by chunk); every problem is an InputError naming the file, line and field.
class TraceParser {
 public:
  TraceParser(const std::string& path, const CsvReadOptions& options, std::size_t total_bytes)
      : path_(path), options_(options), total_bytes_(total_bytes) {}

  // Looks at the first kSniffBytes of the input (all of it when shorter) before any line
  // is parsed, so that a byte-order mark or binary data is named as such whatever else is
  // wrong, and in the same way however the input is cut into pieces.
  void Sniff(std::string_view head) {
    if (head.size() >= 3 && static_cast<unsigned char>(head[0]) == 0xEF &&
        static_cast<unsigned char>(head[1]) == 0xBB &&
        static_cast<unsigned char>(head[2]) == 0xBF) {
      Fail(1, 1, "file starts with a UTF-8 byte-order mark; save it as plain UTF-8/ASCII");
    }
    if (const void* nul = std::memchr(head.data(), '\0', head.size())) {
      const auto* at = static_cast<const char*>(nul);
      Fail(1 + static_cast<long>(std::count(head.data(), at, '\n')), 0,
           "binary data (NUL byte): not a CSV text file");
    }
  }

  // Parses the complete lines at the start of `data` and returns how many bytes they
  // took; at the end of the input (`at_end`) the rest is the last line, without '\n'.
  std::size_t Consume(std::string_view data, bool at_end) {
    std::size_t pos = 0;
    while (pos < data.size()) {
      const void* newline = std::memchr(data.data() + pos, '\n', data.size() - pos);
      if (!newline) break;
      const std::size_t end =
          static_cast<std::size_t>(static_cast<const char*>(newline) - data.data());
      Line(data.substr(pos, end - pos), false);
      pos = end + 1;
    }
    if (at_end && pos < data.size()) {
      Line(data.substr(pos), true);
      pos = data.size();
    }
    bytes_seen_ += pos;
    return pos;
  }

  Trace Finish() {
    if (bytes_seen_ == 0) Fail(0, 0, "empty file: expected a header row such as 't,u,i,w'");
    if (!have_header_) Fail(line_number_, 0, "no header row: expected a row such as 't,u,i,w'");
    if (rows_ == 0) Fail(line_number_, 0, "no data rows after the header");
    for (std::size_t c = 0; c < names_.size(); ++c) trace_.Set(names_[c], std::move(columns_[c]));
    return std::move(trace_);
  }

 private:
  [[noreturn]] void Fail(long line, long column, const std::string& message) const {
    throw InputError(path_, line, column, message);
  }

  void Line(std::string_view line, bool unterminated) {
    ++line_number_;
    if (std::memchr(line.data(), '\0', line.size())) {
      Fail(line_number_, 0, "binary data (NUL byte): not a CSV text file");
    }
    if (!line.empty() && line.back() == '\r') {
      const std::size_t first_cr = line.find('\r');
      if (first_cr + 1 < line.size()) {  // CRs inside too: CR alone ends the lines
        Fail(line_number_, static_cast<long>(first_cr + 1),
             "lines end with CR alone (old Mac line endings); convert the file with mac2unix");
      }
      Fail(line_number_, static_cast<long>(line.size()),
           "line ends with CR (Windows line endings); convert the file with dos2unix");
    }
    // A comment starts with '#', after optional spaces or tabs (so no column name does).
    const std::string_view content = Trim(line);
    const bool comment = !content.empty() && content.front() == '#';
    if (!have_header_) {
      if (comment) {
        CheckText(line);
        trace_.comments.emplace_back(Trim(content.substr(1)));
        return;
      }
      if (content.empty()) Fail(line_number_, 1, "empty line where the header row was expected");
      Header(line);
      return;
    }
    if (blank_line_ > 0) Fail(blank_line_, 1, "empty line inside the data");
    if (line.empty()) {  // fine as the very last line (a second final newline), else an error
      blank_line_ = line_number_;
      return;
    }
    if (comment) Fail(line_number_, 1, "comment line inside the data (only before the header)");
    Row(line, unterminated);
  }

  // Comment and header lines are text: a control byte (but tab) means binary data, a CR
  // inside a line means CR line ends.
  void CheckText(std::string_view line) const {
    for (std::size_t k = 0; k < line.size(); ++k) {
      const unsigned char c = static_cast<unsigned char>(line[k]);
      if (c == '\r') {
        Fail(line_number_, static_cast<long>(k + 1),
             "lines end with CR alone (old Mac line endings); convert the file with mac2unix");
      }
      if ((c < 0x20 && c != '\t') || c == 0x7f) {
        Fail(line_number_, 0, "binary data (control byte " + Hex(c) + "): not a CSV text file");
      }
    }
  }

  void Header(std::string_view line) {
    CheckText(line);
    if (const std::size_t bad = InvalidUtf8(line); bad != std::string_view::npos) {
      Fail(line_number_, 0,
           "header is not UTF-8 text (byte " + Hex(static_cast<unsigned char>(line[bad])) +
               "): a binary file, or a legacy encoding; save it as UTF-8/ASCII");
    }
    std::size_t start = 0;
    long column_index = 0;
    std::unordered_set<std::string> seen;
    const bool single = line.find(',') == std::string_view::npos;
    while (true) {
      ++column_index;
      const std::size_t comma = line.find(',', start);
      std::string_view field =
          Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
      if (field.empty()) Fail(line_number_, column_index, "empty column name in the header");
      if (field.front() == '"' || field.front() == '\'') {
        Fail(line_number_, column_index,
             "quoted column name " + Quote(field) + ": write plain names such as t,u,w");
      }
      for (char c : field) {
        // A single name with a space inside ("t u i w") is a space-separated header.
        if (c == ';' || c == '\t' || c == '|' || (single && c == ' ')) {
          const std::string shown = c == '\t' ? "\\t" : std::string(1, c);
          Fail(line_number_, column_index,
               "header " + Quote(line) + " is not comma separated (found '" + shown +
                   "'); use ',' between columns");
        }
      }
      double ignored = 0.0;
      const auto result = std::from_chars(field.data(), field.data() + field.size(), ignored);
      if (result.ec == std::errc() && result.ptr == field.data() + field.size()) {
        Fail(line_number_, column_index,
             "header expected but found the number " + Quote(field) +
                 ": the first row must name the columns, e.g. t,u,i,w");
      }
      std::string name(field);
      if (!seen.insert(name).second) {
        Fail(line_number_, column_index, "duplicate column name " + QuoteName(name));
      }
      names_.push_back(std::move(name));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    have_header_ = true;
    for (const auto& required : options_.required) {
      if (std::find(names_.begin(), names_.end(), required) == names_.end()) {
        Fail(0, 0,
             "missing required column '" + required + "' (header has: " + HeaderSummary(names_) +
                 ")");
      }
    }
    if (!options_.time_column.empty()) {
      const auto it = std::find(names_.begin(), names_.end(), options_.time_column);
      if (it != names_.end()) time_index_ = static_cast<std::size_t>(it - names_.begin());
    }
    columns_.assign(names_.size(), {});
  }

  static std::string QuoteName(const std::string& name) { return "'" + name + "'"; }

  void Row(std::string_view line, bool unterminated) {
    const char* const end = line.data() + line.size();
    const char* cursor = line.data();
    std::size_t column_index = 0;
    const std::size_t width = names_.size();
    while (true) {
      const char* comma = static_cast<const char*>(
          std::memchr(cursor, ',', static_cast<std::size_t>(end - cursor)));
      const char* field_end = comma ? comma : end;
      if (column_index >= width) {
        Fail(line_number_, static_cast<long>(column_index + 1),
             "too many fields: the header has " + std::to_string(width) + " columns");
      }
      const double value =
          Number(Trim(std::string_view(cursor, static_cast<std::size_t>(field_end - cursor))),
                 column_index, unterminated);
      std::vector<double>& column = columns_[column_index];
      if (column.size() == column.capacity() && column.size() >= 4096) {
        column.reserve(column.size() + column.size() / 4);  // grow by 25 %, not 100 %
      }
      column.push_back(value);
      ++column_index;
      if (!comma) break;
      cursor = comma + 1;
    }
    if (column_index < width) {
      Fail(line_number_, static_cast<long>(column_index + 1),
           "too few fields: expected " + std::to_string(width) + ", found " +
               std::to_string(column_index) + (unterminated ? " (truncated last line?)" : ""));
    }
    if (time_index_ != kNone) {
      const double t = columns_[time_index_].back();
      if (rows_ > 0 && !(t > previous_time_)) {
        Fail(line_number_, static_cast<long>(time_index_ + 1),
             "time '" + options_.time_column + "' must strictly increase (" + DisplayNumber(t) +
                 (t == previous_time_ ? " repeats " : " follows ") + DisplayNumber(previous_time_) +
                 ")");
      }
      previous_time_ = t;
    }
    ++rows_;
    row_bytes_ += line.size() + 1;
    if (rows_ == kEstimateAfterRows) ReserveEstimate();
  }

  double Number(std::string_view field, std::size_t column_index, bool unterminated) const {
    const std::string& name = names_[column_index];
    const long column = static_cast<long>(column_index + 1);
    if (field.empty()) {
      Fail(line_number_, column,
           "column '" + name + "' is empty" + (unterminated ? " (truncated last line?)" : ""));
    }
    double value = 0.0;
    const char* first = field.data();
    if (*first == '+' && field.size() > 1 && field[1] != '-') ++first;  // "+1", not "+-1"
    const auto result = std::from_chars(first, field.data() + field.size(), value);
    if (result.ec == std::errc::result_out_of_range) {
      Fail(line_number_, column,
           "column '" + name + "' value " + Quote(field) + " is out of the double range");
    }
    if (result.ec != std::errc() || result.ptr != field.data() + field.size()) {
      Fail(line_number_, column,
           "column '" + name + "' is not a number (" + Quote(field) + ")" +
               (field.front() == '"' ? "; quoted fields are not supported" : ""));
    }
    if (!std::isfinite(value)) {
      Fail(line_number_, column, "column '" + name + "' is not finite (" + Quote(field) + ")");
    }
    return value == 0.0 ? 0.0 : value;  // -0 reads as 0
  }

  // Reserves the columns for the rows the rest of the input will hold at the mean row
  // length so far (2 % over), so a large file is read without doubling reallocations.
  void ReserveEstimate() {
    if (total_bytes_ <= bytes_seen_) return;
    const double per_row = static_cast<double>(row_bytes_) / static_cast<double>(rows_);
    const double rest = static_cast<double>(total_bytes_ - bytes_seen_) / per_row;
    const std::size_t rows = rows_ + static_cast<std::size_t>(rest * 1.02) + 64;
    for (auto& column : columns_) column.reserve(rows);
  }

  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  static constexpr std::size_t kEstimateAfterRows = 256;

  const std::string& path_;
  const CsvReadOptions& options_;
  const std::size_t total_bytes_;  // size of the whole input (for the estimate), or 0
  std::size_t bytes_seen_ = 0;     // bytes of the complete lines consumed
  long line_number_ = 0;
  long blank_line_ = 0;  // an empty data line waiting to be known as the last one
  bool have_header_ = false;
  std::vector<std::string> names_;
  std::vector<std::vector<double>> columns_;
  std::size_t time_index_ = kNone;
  double previous_time_ = 0.0;
  std::size_t rows_ = 0;
  std::size_t row_bytes_ = 0;
  Trace trace_;
};

}  // namespace

Trace ReadTraceCsv(const std::string& path, const CsvReadOptions& options, std::string* sha256) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot read: " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  struct stat info {};
  if (fstat(fd, &info) != 0) throw InputError(path + ": cannot read: " + std::strerror(errno));
  if (S_ISDIR(info.st_mode)) throw InputError(path + ": cannot read: " + std::strerror(EISDIR));
  const std::size_t size = S_ISREG(info.st_mode) ? static_cast<std::size_t>(info.st_size) : 0;
  auto read_some = [&](char* into, std::size_t bytes) {
    while (true) {
      const ssize_t n = read(fd, into, bytes);
      if (n >= 0) return static_cast<std::size_t>(n);
      if (errno != EINTR) throw InputError(path + ": cannot read: " + std::strerror(errno));
    }
  };
  TraceParser parser(path, options, size);
  Sha256 hash;
  // Chunks of options.read_chunk_bytes; the part of a line that straddles two chunks is
  // moved to the front, and a line longer than the buffer doubles it. The first
  // kSniffBytes are gathered before any line is parsed.
  const std::size_t chunk = std::max<std::size_t>(1, options.read_chunk_bytes);
  std::vector<char> buffer(std::max(kSniffBytes, std::min(chunk, size + 1)));
  std::size_t held = 0;
  bool at_end = false;
  while (held < kSniffBytes && !at_end) {
    const std::size_t n = read_some(buffer.data() + held, std::min(chunk, kSniffBytes - held));
    at_end = n == 0;
    held += n;
  }
  parser.Sniff(std::string_view(buffer.data(), held));
  if (sha256) hash.Update(std::string_view(buffer.data(), held));
  while (true) {
    // Parse what is held in chunk-sized windows (the first pass parses the sniffed head).
    std::size_t start = 0;
    while (start < held) {
      const std::size_t window = std::min(held - start, chunk);
      const bool last = at_end && start + window == held;
      const std::size_t used =
          parser.Consume(std::string_view(buffer.data() + start, window), last);
      if (used == 0 && !last) {
        if (start + window == held) break;  // an incomplete line: read more
        // A line longer than the window: widen it to everything held.
        const std::size_t wide =
            parser.Consume(std::string_view(buffer.data() + start, held - start), at_end);
        start += wide;
        break;
      }
      start += used;
      if (last) break;
    }
    std::memmove(buffer.data(), buffer.data() + start, held - start);
    held -= start;
    if (at_end) break;
    if (held == buffer.size()) buffer.resize(buffer.size() * 2);
    const std::size_t n = read_some(buffer.data() + held, std::min(chunk, buffer.size() - held));
    if (sha256) hash.Update(std::string_view(buffer.data() + held, n));
    held += n;
    at_end = n == 0;
  }
  Trace trace = parser.Finish();
  if (sha256) *sha256 = hash.HexDigest();
  return trace;
}

Trace ParseTraceCsv(const std::string& text, const std::string& path,
                    const CsvReadOptions& options) {
  TraceParser parser(path, options, text.size());
  parser.Sniff(std::string_view(text).substr(0, kSniffBytes));
  parser.Consume(text, true);
  return parser.Finish();
}

std::string HeaderSummary(const std::vector<std::string>& names) {
  constexpr std::size_t kMax = 80;
  std::string out;
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::string_view name = names[k];
    if (out.size() + name.size() + 1 > kMax) {
      const std::string count = ",... (" + std::to_string(names.size()) + " columns)";
      if (k > 0) return out + count;
      return std::string(name.substr(0, 40)) + "..." + (names.size() > 1 ? count : "");
    }
    out += (k ? "," : "") + std::string(name);
  }
  return out;
}

std::string FormatSignificant(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

std::string FormatNumber(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string DisplayNumber(double value) {
  const std::string shortest = FormatNumber(value);
  char buffer[400];
  const auto result =
      std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed);
  if (result.ec != std::errc()) return shortest;
  std::string fixed(buffer, result.ptr);
  return fixed.size() <= shortest.size() + 2 ? fixed : shortest;
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
