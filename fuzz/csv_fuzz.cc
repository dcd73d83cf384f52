// libFuzzer target for the trace CSV reader (blmd::ParseTraceCsv, docs/trace-format.md).
// Besides "no crash, no sanitizer report", every input must end one of two ways:
//  - an InputError whose message is one printable line starting with the file name;
//  - a trace that keeps the reader's promises: columns of equal length, at least one row,
//    finite values, no -0, t strictly increasing, and a write-read round trip that is exact
//    bit for bit.
// And reading the same bytes from a file in small pieces (ReadTraceCsv with a piece size
// taken from the input) must give the same trace or the same message.
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
  std::fprintf(stderr, "csv_fuzz: %s %s\n", what, detail.c_str());
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
  const blmd::Trace back =
      blmd::ParseTraceCsv(blmd::FormatTraceCsv(trace), "round-trip.csv", options);
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

// The same bytes through a file read in pieces (an in-memory file: memfd).
void CheckPieces(const std::string& text, std::size_t piece, const blmd::Trace* whole,
                 const std::string& whole_error) {
  static const int fd = memfd_create("csv_fuzz", 0);
  if (fd < 0) return;
  if (ftruncate(fd, 0) != 0 ||
      pwrite(fd, text.data(), text.size(), 0) != static_cast<ssize_t>(text.size())) {
    return;
  }
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  blmd::CsvReadOptions options;
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
  // The first byte chooses the options: required columns and the piece size.
  const std::uint8_t control = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  blmd::CsvReadOptions options;
  if (control & 1) options.required = {"t", "u"};
  if (control & 2) options.time_column = "";
  const std::size_t piece = 1 + (control >> 2);
  const std::string path = "fuzz.csv";
  try {
    const blmd::Trace trace = blmd::ParseTraceCsv(text, path, options);
    CheckTrace(trace, options);
    if (options.required.empty() && options.time_column == "t")
      CheckPieces(text, piece, &trace, "");
  } catch (const blmd::InputError& error) {
    CheckMessage(error.what(), path);
    if (options.required.empty() && options.time_column == "t")
      CheckPieces(text, piece, nullptr, error.what());
  }
  return 0;
}
