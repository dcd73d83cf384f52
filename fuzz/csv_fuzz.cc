// libFuzzer target for the trace CSV reader (blmd::ParseTraceCsv, docs/trace-format.md).
// Besides "no crash, no sanitizer report", every input must end one of two ways:
//  - an InputError whose message is one printable line starting with the file name;
//  - a trace that keeps the reader's promises: columns of equal length, at least one row,
//    finite values, no -0, t strictly increasing, and a write-read round trip that is exact
//    bit for bit.
// And reading the same bytes from a file in small pieces (ReadTraceCsv with a piece size
// taken from the input) must give the same trace or the same message.
#include "trace_checks.h"

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
    fuzz::CheckTrace(trace, options);
    if (options.required.empty() && options.time_column == "t")
      fuzz::CheckPieces(text, options, piece, &trace, "");
  } catch (const blmd::InputError& error) {
    fuzz::CheckMessage(error.what(), path);
    if (options.required.empty() && options.time_column == "t")
      fuzz::CheckPieces(text, options, piece, nullptr, error.what());
  }
  return 0;
}
