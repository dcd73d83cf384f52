// Trace CSV (docs/trace-format.md): optional '#' comment lines, one header
// row, plain decimal numbers. What real loggers write is accepted: LF or CRLF line ends,
// ',' or ';' (or tab) between fields (detected from the header, or given), double-quoted
// names and fields (RFC 4180), a decimal comma in ';'-separated files, and text or empty
// cells in the columns a command does not use. The columns it uses are read strictly:
// every problem is an InputError naming file:line:column, the column and what was expected.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "blmd/format.h"
#include "blmd/sim/trace.h"

namespace blmd {

// Rows that share one time stamp (loggers write several per tick): an error naming the flag
// (the default), the first row of each instant kept, or every column averaged over them.
enum class DuplicateTime { kError, kFirst, kMean };

struct CsvReadOptions {
  // Columns that must be present (the error names the first missing one).
  std::vector<std::string> required;
  // Column whose values must strictly increase (empty: none).
  std::string time_column = "t";
  // ReadTraceCsv reads the file this many bytes at a time (tests use tiny pieces to check
  // that lines cut between reads are read the same).
  std::size_t read_chunk_bytes = std::size_t{4} << 20;
  // The columns (header names) read strictly: every cell a finite number. A column not
  // listed that holds text or an empty cell anywhere is left out of the trace (one whose
  // every cell is a number is kept). Empty: every column is read strictly.
  std::vector<std::string> strict_columns;
  // Field separator: ',', ';' or '\t'; 0 detects it from the header (',' when the header
  // has one outside quotes, else ';', else tab, else ',').
  char delimiter = 0;
  DuplicateTime duplicate_time = DuplicateTime::kError;
  // A file without a header row (a logger's dump): when not empty, these name its columns in
  // order and its first line that is not a comment is data; every row must have this many
  // fields. The names are checked as a header's are (none empty, none repeated, none a number).
  std::vector<std::string> names;
  // > 0: the file has no time column and its rows are samples at this rate (Hz): a column
  // named time_column ("t" when that is empty) is made after the file's, t = k / sample_rate
  // for row k = 0, 1, ... (no two rows share a time, so duplicate_time has nothing to merge).
  // A file that has such a column is an error.
  double sample_rate = 0.0;
};

// Reads the file in chunks (the text is never held whole: memory is about the numbers'
// size, 8 bytes per value). When `sha256` is given it receives the SHA-256 of the bytes.
// A MATLAB .mat file (IsMatFile, io/mat.h) is read by ReadTraceMat instead, so every reader
// of traces takes both.
Trace ReadTraceCsv(const std::string& path, const CsvReadOptions& options = {},
                   std::string* sha256 = nullptr);
// Parses CSV text; `path` only labels errors.
Trace ParseTraceCsv(const std::string& text, const std::string& path,
                    const CsvReadOptions& options = {});
// Parses CSV text handed over in pieces (cut anywhere): `next_piece` returns the next one,
// an empty string at the end. ReadTraceMat writes a MAT file's columns as rows through it.
Trace ParseTraceCsvPieces(const std::function<std::string()>& next_piece, const std::string& path,
                          const CsvReadOptions& options = {});

// A header for a message: the names joined by ',', cut after about 80 characters with
// ",... (N columns)" so that one line stays one readable line.
std::string HeaderSummary(const std::vector<std::string>& names);

std::string FormatTraceCsv(const Trace& trace);
// Written to a temporary file in the same folder, then renamed (atomic).
void WriteTraceCsv(const Trace& trace, const std::string& path);

}  // namespace blmd
