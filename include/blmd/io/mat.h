// MATLAB .mat traces (docs/trace-format.md, "MATLAB .mat files"), read through libmatio:
// MAT v4, v5/v7 and v7.3 (HDF5). Each real numeric vector variable is a column named by the
// variable, each column k of a 2-D matrix M a column "M:k" (1-based), each such field f of a
// 1x1 struct s a column "s.f". Scalars, text, cells and the like are not columns: they are
// left out unless a command uses their name, which is then an InputError naming the variable
// and its class. The columns become CSV rows for the CSV reader (ParseTraceCsvPieces), so a
// .mat trace meets the same checks (time order, --duplicate-time, required and strict
// columns) with the same messages; their line L is element L-1 of the variables.
#pragma once

#include <string>

#include "blmd/io/csv.h"
#include "blmd/sim/trace.h"

namespace blmd {

// True when `path` ends in ".mat" (any case) or is a regular file that starts with the
// 128-byte header of MAT v5/v7/v7.3 ("MATLAB" text, version 0x0100 or 0x0200, endian mark).
bool IsMatFile(const std::string& path);

// Reads a MAT file as a trace, with the options of a CSV file (the delimiter is ignored).
// When `sha256` is given it receives the SHA-256 of the file's bytes.
Trace ReadTraceMat(const std::string& path, const CsvReadOptions& options = {},
                   std::string* sha256 = nullptr);

}  // namespace blmd
