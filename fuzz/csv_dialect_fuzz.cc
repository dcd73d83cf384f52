// libFuzzer target for the trace reader's dialects (docs/trace-format.md, issue 18): CRLF
// line ends, double-quoted names and fields, ';' and tab separators with decimal commas,
// text and empty cells in the columns not read strictly, repeated time stamps merged
// (first, mean). The first byte chooses the options; the rest is the file. Every input must
// end one of two ways:
//  - an InputError whose message is one printable line starting with the file name;
//  - a trace that keeps the reader's promises (columns of equal length, at least one row,
//    finite values, no -0, t strictly increasing when checked), that a write-read round
//    trip (FormatTraceCsv, then the default strict reader) gives back bit for bit, names
//    included (quoted where they need it);
// and reading the same bytes from a file in small pieces gives the same trace or message.
#include <sys/mman.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "blmd/error.h"
#include "blmd/io/csv.h"

namespace {

[[noreturn]] void Broken(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "csv_dialect_fuzz: %s %s\n", what, detail.c_str());
  std::abort();
}

void CheckMessage(const std::string& message, const std::string& path) {
  if (message.rfind(path, 0) != 0) Broken("message does not start with the file name:", message);
  for (const char c : message) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) Broken("control character in the message:", message);
  }
  if (message.size() > 1000) Broken("message longer than 1000 bytes");
}

void CheckTrace(const blmd::Trace& trace, const blmd::CsvReadOptions& options) {
  if (trace.rows() == 0) Broken("a trace without rows");
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    const auto& column = trace.Column(c);
    if (column.size() != trace.rows()) Broken("columns of unequal length");
    for (double v : column) {
      if (!std::isfinite(v)) Broken("a non-finite value");
      if (v == 0.0 && std::signbit(v)) Broken("-0 kept");
    }
  }
  if (!options.time_column.empty() && trace.Has(options.time_column)) {
    const auto& t = trace.Column(options.time_column);
    for (std::size_t k = 1; k < t.size(); ++k) {
      if (!(t[k] > t[k - 1])) Broken("t not strictly increasing");
    }
  }
  // Written back (comma separated, names quoted where needed) and read by the default,
  // strict reader: the same names and the same bits.
  blmd::CsvReadOptions strict;
  strict.time_column = options.time_column;
  const blmd::Trace back = blmd::ParseTraceCsv(blmd::FormatTraceCsv(trace), "round-trip.csv", strict);
  if (back.names() != trace.names() || back.rows() != trace.rows()) Broken("round trip shape");
  for (std::size_t c = 0; c < trace.num_columns(); ++c) {
    for (std::size_t r = 0; r < trace.rows(); ++r) {
      if (std::bit_cast<std::uint64_t>(back.Column(c)[r]) !=
          std::bit_cast<std::uint64_t>(trace.Column(c)[r])) {
        Broken("round trip not bit-exact");
      }
    }
  }
}

void CheckPieces(const std::string& text, const blmd::CsvReadOptions& whole_options,
                 std::size_t piece, const blmd::Trace* whole, const std::string& whole_error) {
  static const int fd = memfd_create("csv_dialect_fuzz", 0);
  if (fd < 0) return;
  if (ftruncate(fd, 0) != 0 ||
      pwrite(fd, text.data(), text.size(), 0) != static_cast<ssize_t>(text.size())) {
    return;
  }
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  blmd::CsvReadOptions options = whole_options;
  options.read_chunk_bytes = piece;
  try {
    const blmd::Trace read = blmd::ReadTraceCsv(path, options);
    if (!whole) Broken("pieces read what the whole text rejects:", whole_error);
    if (read.names() != whole->names() || read.comments != whole->comments)
      Broken("pieces: header");
    for (std::size_t c = 0; c < read.num_columns(); ++c) {
      if (read.Column(c) != whole->Column(c)) Broken("pieces: values");
    }
  } catch (const blmd::InputError& error) {
    std::string message = error.what();
    message.replace(0, path.size(), "fuzz.csv");
    if (whole) Broken("pieces reject what the whole text reads:", message);
    if (message != whole_error) Broken("pieces: another message:", message + " vs " + whole_error);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // First byte: bits 0-1 separator (detect, ',', ';', tab), bits 2-3 repeated times (error,
  // first, mean, error), bit 4 only t and u read strictly, bits 5-7 piece size - 1.
  const std::uint8_t control = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  blmd::CsvReadOptions options;
  static const char kDelimiters[] = {0, ',', ';', '\t'};
  options.delimiter = kDelimiters[control & 3];
  const int duplicates = (control >> 2) & 3;
  options.duplicate_time = duplicates == 1   ? blmd::DuplicateTime::kFirst
                           : duplicates == 2 ? blmd::DuplicateTime::kMean
                                             : blmd::DuplicateTime::kError;
  if (control & 16) options.strict_columns = {"t", "u"};
  const std::size_t piece = 1 + (control >> 5);
  const std::string path = "fuzz.csv";
  try {
    const blmd::Trace trace = blmd::ParseTraceCsv(text, path, options);
    CheckTrace(trace, options);
    CheckPieces(text, options, piece, &trace, "");
  } catch (const blmd::InputError& error) {
    CheckMessage(error.what(), path);
    CheckPieces(text, options, piece, nullptr, error.what());
  }
  return 0;
}
