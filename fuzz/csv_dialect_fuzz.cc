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
#include "trace_checks.h"

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
    fuzz::CheckTrace(trace, options);
    fuzz::CheckPieces(text, options, piece, &trace, "");
  } catch (const blmd::InputError& error) {
    fuzz::CheckMessage(error.what(), path);
    fuzz::CheckPieces(text, options, piece, nullptr, error.what());
  }
  return 0;
}
