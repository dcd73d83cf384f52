#include "blmd/io/csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <unordered_set>

#include "blmd/error.h"
#include "blmd/io/files.h"
#include "blmd/io/mat.h"
#include "io/readable_file.h"

namespace blmd {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Whether the whole of `s` reads as a number (a column's name must not).
bool IsNumber(std::string_view s) {
  double ignored = 0.0;
  const auto result = std::from_chars(s.data(), s.data() + s.size(), ignored);
  return result.ec == std::errc() && result.ptr == s.data() + s.size();
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
    // Linear in the number of columns: names are unique (checked in the header).
    for (std::size_t c = 0; c < names_.size(); ++c) {
      if (!text_[c]) trace_.Append(names_[c], std::move(columns_[c]));
    }
    // --sample-rate: the time column made, after the file's (whose field numbers stay theirs).
    if (options_.sample_rate > 0.0) {
      std::vector<double> t(rows_);
      for (std::size_t k = 0; k < rows_; ++k) {
        t[k] = static_cast<double>(k) / options_.sample_rate;
      }
      trace_.Append(options_.time_column.empty() ? "t" : options_.time_column, std::move(t));
    }
    if (trace_.num_columns() == 0) {
      Fail(0, 0,
           "no column holds a number in every row (columns with text or empty cells are "
           "left out when not used)");
    }
    if (merged_rows_ > 0) {
      trace_.comments.push_back(
          "read with --duplicate-time " +
          std::string(options_.duplicate_time == DuplicateTime::kMean ? "mean" : "first") + ": " +
          std::to_string(merged_rows_) + " repeated-time rows merged");
    }
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
    // CRLF (Windows) line ends: the CR is part of the line end. A CR anywhere else means CR
    // alone ends the lines (old Mac), which is not read.
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (const std::size_t cr = line.find('\r'); cr != std::string_view::npos) {
      Fail(line_number_, static_cast<long>(cr + 1),
           "lines end with CR alone (old Mac line endings); convert the file with mac2unix");
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
      if (options_.names.empty()) {
        Header(line);
        return;
      }
      GivenNames(line);  // no header row: this line is the first row of data
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

  // The separator of a header line: options_.delimiter, else ',' when the line has one
  // outside double quotes, else ';', else tab, else ','.
  char DetectDelimiter(std::string_view line) const {
    if (options_.delimiter != 0) return options_.delimiter;
    bool quoted = false, semicolon = false, tab = false;
    for (const char c : line) {
      if (c == '"') quoted = !quoted;
      if (quoted) continue;
      if (c == ',') return ',';
      semicolon = semicolon || c == ';';
      tab = tab || c == '\t';
    }
    return semicolon ? ';' : tab ? '\t' : ',';
  }

  // Splits a line at the separator outside double quotes into fields_, each trimmed and
  // unquoted ("" inside quotes is one "); returns the 1-based field of an unclosed quote,
  // or 0. Lines without a quote (the usual case) are cut without copying.
  long Split(std::string_view line) {
    fields_.clear();
    if (line.find('"') == std::string_view::npos) {
      std::size_t start = 0;
      while (true) {
        const void* found = std::memchr(line.data() + start, delimiter_, line.size() - start);
        const std::size_t end =
            found ? static_cast<std::size_t>(static_cast<const char*>(found) - line.data())
                  : line.size();
        fields_.push_back(Trim(line.substr(start, end - start)));
        if (!found) return 0;
        start = end + 1;
      }
    }
    unquoted_.clear();
    std::vector<std::pair<std::size_t, std::size_t>> spans;  // into unquoted_
    std::string field;
    bool quoted = false, was_quoted = false;
    long index = 1;
    auto finish = [&] {
      std::string_view view = field;
      if (!was_quoted) view = Trim(view);
      spans.emplace_back(unquoted_.size(), view.size());
      unquoted_ += view;
      field.clear();
      was_quoted = false;
      ++index;
    };
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
      } else if (c == '"' && Trim(field).empty()) {
        quoted = was_quoted = true;
        field.clear();
      } else if (c == delimiter_) {
        finish();
      } else if (!(was_quoted && (c == ' ' || c == '\t'))) {
        field += c;
      }
    }
    if (quoted) return index;
    finish();
    for (const auto& [offset, size] : spans) {
      fields_.push_back(std::string_view(unquoted_).substr(offset, size));
    }
    return 0;
  }

  void Header(std::string_view line) {
    CheckText(line);
    if (const std::size_t bad = InvalidUtf8(line); bad != std::string_view::npos) {
      Fail(line_number_, 0,
           "header is not UTF-8 text (byte " + Hex(static_cast<unsigned char>(line[bad])) +
               "): a binary file, or a legacy encoding; save it as UTF-8/ASCII");
    }
    delimiter_ = DetectDelimiter(line);
    const bool any_quote = line.find('"') != std::string_view::npos;
    if (const long open = Split(line)) {
      Fail(line_number_, open, "unclosed quote in the header (a '\"' without its closing '\"')");
    }
    std::unordered_set<std::string> seen;
    const bool single = fields_.size() == 1;
    long column_index = 0;
    for (const std::string_view field : fields_) {
      ++column_index;
      if (field.empty()) Fail(line_number_, column_index, "empty column name in the header");
      if (field.front() == '\'') {
        Fail(line_number_, column_index,
             "quoted column name " + Quote(field) +
                 ": write plain names such as t,u,w, or "
                 "double quotes");
      }
      for (char c : any_quote ? std::string_view() : field) {
        // Another separator inside a name: the file uses one we do not read ('|', or
        // spaces: a single name with a space inside, "t u i w").
        if (c == '|' || (c == ';' && delimiter_ != ';') || (c == '\t' && delimiter_ != '\t') ||
            (single && c == ' ')) {
          const std::string shown = c == '\t' ? "\\t" : std::string(1, c);
          Fail(line_number_, column_index,
               "header " + Quote(line) + " is not comma separated (found '" + shown +
                   "'); use ',' between columns");
        }
      }
      if (IsNumber(field)) {
        Fail(line_number_, column_index,
             "header expected but found the number " + Quote(field) +
                 ": the first row must name the columns, e.g. t,u,i,w");
      }
      std::string name(field);
      if (!seen.insert(name).second) {
        Fail(line_number_, column_index, "duplicate column name " + QuoteName(name));
      }
      names_.push_back(std::move(name));
    }
    SetUpColumns();
  }

  // --no-header: the names come from the options; the separator from the first data line.
  void GivenNames(std::string_view line) {
    CheckText(line);
    delimiter_ = DetectDelimiter(line);
    std::unordered_set<std::string> seen;
    for (const std::string& name : options_.names) {
      if (name.empty() || IsNumber(name)) {
        Fail(0, 0,
             "--no-header: column name " + QuoteName(name) +
                 " is empty or a number; name the columns, e.g. --no-header u,theta");
      }
      if (!seen.insert(name).second) {
        Fail(0, 0, "--no-header: duplicate column name " + QuoteName(name));
      }
      names_.push_back(name);
    }
    SetUpColumns();
  }

  std::string HeaderLabel() const {
    return options_.names.empty() ? "the header has" : "--no-header names";
  }

  void SetUpColumns() {
    have_header_ = true;
    if (options_.sample_rate > 0.0) {
      const std::string time = options_.time_column.empty() ? "t" : options_.time_column;
      if (std::find(names_.begin(), names_.end(), time) != names_.end()) {
        Fail(0, 0,
             "--sample-rate: the file has a time column '" + time +
                 "' already; give one or the other");
      }
    }
    for (const auto& required : options_.required) {
      if (options_.sample_rate > 0.0 &&
          required == (options_.time_column.empty() ? "t" : options_.time_column)) {
        continue;  // made from the rate
      }
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
    const std::unordered_set<std::string> strict(options_.strict_columns.begin(),
                                                 options_.strict_columns.end());
    strict_.assign(names_.size(), 1);
    if (!strict.empty()) {
      for (std::size_t c = 0; c < names_.size(); ++c) {
        strict_[c] = c == time_index_ || strict.count(names_[c]) ? 1 : 0;
      }
    }
    text_.assign(names_.size(), 0);
    columns_.assign(names_.size(), {});
  }

  // A column name in a message: at most 80 bytes of it (a quoted header name may be a line long).
  static std::string QuoteName(const std::string& name) {
    return "'" + InputError::Excerpt(name) + "'";
  }

  void Row(std::string_view line, bool unterminated) {
    const std::size_t width = names_.size();
    if (const long open = Split(line)) {
      Fail(line_number_, open, "unclosed quote (a '\"' without its closing '\"')");
    }
    if (fields_.size() > width) {
      Fail(line_number_, static_cast<long>(width + 1),
           "too many fields: " + HeaderLabel() + " " + std::to_string(width) + " columns" +
               (delimiter_ == ','    ? ""
                : delimiter_ == '\t' ? std::string(" (separator tab)")
                                     : std::string(" (separator '") + delimiter_ + "')"));
    }
    for (std::size_t c = 0; c < fields_.size(); ++c) {
      double value;
      if (strict_[c]) {
        value = Number(fields_[c], c, unterminated);
      } else if (!Parse(fields_[c], &value)) {  // text or empty in a column not used: dropped
        text_[c] = 1;
        value = 0.0;
      }
      std::vector<double>& column = columns_[c];
      if (column.size() == column.capacity() && column.size() >= 4096) {
        column.reserve(column.size() + column.size() / 4);  // grow by 25 %, not 100 %
      }
      column.push_back(value);
    }
    if (fields_.size() < width) {
      for (std::size_t c = 0; c < fields_.size(); ++c) columns_[c].pop_back();
      Fail(line_number_, static_cast<long>(fields_.size() + 1),
           "too few fields: expected " + std::to_string(width) + ", found " +
               std::to_string(fields_.size()) + (unterminated ? " (truncated last line?)" : ""));
    }
    if (time_index_ != kNone) {
      const double t = columns_[time_index_].back();
      if (rows_ > 0 && t == previous_time_ && options_.duplicate_time != DuplicateTime::kError) {
        MergeDuplicate();
        return;
      }
      if (rows_ > 0 && !(t > previous_time_)) {
        const bool repeat = t == previous_time_;
        Fail(line_number_, static_cast<long>(time_index_ + 1),
             "time '" + options_.time_column + "' must strictly increase (" + DisplayNumber(t) +
                 (repeat ? " repeats " : " follows ") + DisplayNumber(previous_time_) +
                 (repeat ? " of line " + std::to_string(group_line_) +
                               "); for several rows logged at one instant use "
                               "--duplicate-time first|mean"
                         : ")"));
      }
      previous_time_ = t;
      group_line_ = line_number_;
      group_rows_ = 1;
    }
    ++rows_;
    row_bytes_ += line.size() + 1;
    if (rows_ == kEstimateAfterRows) ReserveEstimate();
  }

  // The row just read repeats the previous row's time: keep the first row of the instant
  // (kFirst), or fold the new row into the running mean of the instant's rows (kMean).
  void MergeDuplicate() {
    ++group_rows_;
    const double n = static_cast<double>(group_rows_);
    for (auto& column : columns_) {
      const double value = column.back();
      column.pop_back();
      if (options_.duplicate_time == DuplicateTime::kMean) {
        column.back() += (value - column.back()) / n;
        if (column.back() == 0.0) column.back() = 0.0;  // never -0
      }
    }
    ++merged_rows_;
  }

  // A lenient number (a column not used): true and the value when the field is one.
  static bool Parse(std::string_view field, double* value) {
    if (field.empty()) return false;
    const char* first = field.data();
    if (*first == '+' && field.size() > 1 && field[1] != '-') ++first;
    const auto result = std::from_chars(first, field.data() + field.size(), *value);
    if (*value == 0.0) *value = 0.0;  // -0 reads as 0
    return result.ec == std::errc() && result.ptr == field.data() + field.size() &&
           std::isfinite(*value);
  }

  double Number(std::string_view field, std::size_t column_index, bool unterminated) const {
    const std::string& name = names_[column_index];
    const long column = static_cast<long>(column_index + 1);
    if (field.empty()) {
      Fail(line_number_, column,
           "column " + QuoteName(name) + " is empty" +
               (unterminated ? " (truncated last line?)" : ""));
    }
    double value = 0.0;
    // A decimal comma ("0,5") in a ';'-separated file, as European spreadsheets write it.
    char decimal[64];
    if (delimiter_ == ';' && field.size() < sizeof decimal &&
        std::count(field.begin(), field.end(), ',') == 1 &&
        field.find('.') == std::string_view::npos) {
      std::memcpy(decimal, field.data(), field.size());
      *std::find(decimal, decimal + field.size(), ',') = '.';
      field = std::string_view(decimal, field.size());
    }
    const char* first = field.data();
    if (*first == '+' && field.size() > 1 && field[1] != '-') ++first;  // "+1", not "+-1"
    const auto result = std::from_chars(first, field.data() + field.size(), value);
    if (result.ec == std::errc::result_out_of_range) {
      Fail(line_number_, column,
           "column " + QuoteName(name) + " value " + Quote(field) + " is out of the double range");
    }
    if (result.ec != std::errc() || result.ptr != field.data() + field.size()) {
      Fail(line_number_, column,
           "column " + QuoteName(name) + " is not a number (" + Quote(field) + ")");
    }
    if (!std::isfinite(value)) {
      Fail(line_number_, column,
           "column " + QuoteName(name) + " is not finite (" + Quote(field) + ")");
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
  char delimiter_ = ',';
  std::vector<std::string_view> fields_;  // the current line's fields (Split)
  std::string unquoted_;                  // their text when a line had quotes
  std::vector<char> strict_;              // per column: read strictly
  std::vector<char> text_;                // per column (not strict): held text or an empty cell
  long group_line_ = 0;                   // line of the first row of the current time
  std::size_t group_rows_ = 0;            // rows of the current time so far
  std::size_t merged_rows_ = 0;           // rows folded into an earlier one (duplicate_time)
  std::size_t rows_ = 0;
  std::size_t row_bytes_ = 0;
  Trace trace_;
};

}  // namespace

Trace ReadTraceCsv(const std::string& path, const CsvReadOptions& options, std::string* sha256) {
  if (IsMatFile(path)) return ReadTraceMat(path, options, sha256);
  const internal::ReadableFile file(path);
  const std::size_t size = file.size();
  auto read_some = [&](char* into, std::size_t bytes) { return file.ReadSome(into, bytes); };
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

Trace ParseTraceCsvPieces(const std::function<std::string()>& next_piece, const std::string& path,
                          const CsvReadOptions& options) {
  TraceParser parser(path, options, 0);
  std::string held = next_piece();
  parser.Sniff(std::string_view(held).substr(0, kSniffBytes));
  while (true) {
    std::string piece = next_piece();
    const bool at_end = piece.empty();
    held.erase(0, parser.Consume(held, at_end));  // keeps a line cut between pieces
    if (at_end) break;
    held += piece;
  }
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

namespace {

// A column name as a header field: double-quoted (RFC 4180, "" for ") when it would not read
// back as itself plainly: a separator, quote, '|' or space inside (a lone name with a space
// reads as a space-separated header), a leading '#' or single quote.
std::string HeaderField(const std::string& name) {
  const bool plain = name.find_first_of(",;\t\"| ") == std::string::npos && !name.empty() &&
                     name.front() != '#' && name.front() != '\'';
  if (plain) return name;
  std::string out = "\"";
  for (const char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string FormatTraceCsv(const Trace& trace) {
  std::string out;
  for (const auto& comment : trace.comments) out += "# " + comment + "\n";
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    out += (c ? "," : "") + HeaderField(trace.names()[c]);
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
