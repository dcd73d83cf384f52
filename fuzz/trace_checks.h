// The reader's promises, checked by the trace fuzz targets (csv_fuzz, csv_dialect_fuzz):
// every input ends in a one-line InputError naming the file, or in a trace whose columns
// are equal and finite (no -0), whose time strictly increases when checked, that a write and
// a strict read give back bit for bit, names included; and a file read in small pieces
// gives the same trace or the same message as the whole text.
#pragma once

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

namespace fuzz {

[[noreturn]] inline void Broken(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "trace fuzz: %s %s\n", what, detail.c_str());
  std::abort();
}

inline void CheckMessage(const std::string& message, const std::string& path) {
  if (message.rfind(path, 0) != 0) Broken("message does not start with the file name:", message);
  for (const char c : message) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) Broken("control character in the message:", message);
  }
  if (message.size() > 1000) Broken("message longer than 1000 bytes");
}

inline void CheckTrace(const blmd::Trace& trace, const blmd::CsvReadOptions& options) {
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
  // Written back (comma separated, names quoted where needed) and read by the strict reader.
  blmd::CsvReadOptions strict;
  strict.time_column = options.time_column;
  const blmd::Trace back =
      blmd::ParseTraceCsv(blmd::FormatTraceCsv(trace), "round-trip.csv", strict);
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

// The same bytes through a file (an in-memory file: memfd) read `piece` bytes at a time,
// with the same options: the same trace as `whole`, or the same message as `whole_error`.
inline void CheckPieces(const std::string& text, const blmd::CsvReadOptions& whole_options,
                        std::size_t piece, const blmd::Trace* whole,
                        const std::string& whole_error) {
  static const int fd = memfd_create("trace_fuzz", 0);
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

}  // namespace fuzz
