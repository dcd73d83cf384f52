#include "blmd/ident/trace_input.h"

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"

namespace blmd {

std::vector<double> Differentiate(const std::vector<double>& t, const std::vector<double>& x) {
  const std::size_t n = x.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  d[0] = (x[1] - x[0]) / (t[1] - t[0]);
  d[n - 1] = (x[n - 1] - x[n - 2]) / (t[n - 1] - t[n - 2]);
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (x[k + 1] - x[k - 1]) / (t[k + 1] - t[k - 1]);
  return d;
}

FitTrace LoadFitTrace(const std::string& path, const TraceInputOptions& options,
                      const InitialState& default_initial) {
  CsvReadOptions csv;
  // The reader checks the file's time column (the header mapped to t); scaling may still
  // reverse it, so t is checked again below.
  const auto t_header = options.columns.find("t");
  csv.time_column = t_header == options.columns.end() ? "t" : t_header->second;
  std::string sha256;
  Trace trace = ReadTraceCsv(path, csv, &sha256);
  // Column mapping: header -> standard name.
  for (const auto& [standard, header] : options.columns) {
    if (!trace.Has(header)) {
      throw InputError(path + ": --column " + standard + "=" + header + ": no column '" + header +
                       "' (header has: " + HeaderSummary(trace.names()) + ")");
    }
    if (standard != header && trace.Has(standard)) {
      trace.Rename(standard, standard + "_original");
    }
    if (standard != header) trace.Set(standard, trace.Column(header));
  }
  for (const auto& [name, factor] : options.scales) {
    if (!trace.Has(name)) throw InputError(path + ": --scale " + name + ": no column '" + name + "'");
    for (double& v : trace.Column(name)) v *= factor;
  }
  std::vector<std::string> required = {"t", "u"};
  for (const auto& [target, source] : options.derive) required.push_back(source);
  for (const auto& name : required) {
    if (!trace.Has(name)) {
      throw InputError(path + ": missing required column '" + name + "' (header has: " +
                       HeaderSummary(trace.names()) + "; map another header with --column " +
                       name + "=HEADER)");
    }
  }
  const auto& t = trace.Column("t");
  const long t_field = trace.Find(csv.time_column) + 1;  // the file's field of the time
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (!(t[k] > t[k - 1])) {
      throw InputError(path, static_cast<long>(trace.comments.size() + k + 2), t_field,
                       "time 't' must strictly increase (" + DisplayNumber(t[k]) +
                           (t[k] == t[k - 1] ? " repeats " : " follows ") + DisplayNumber(t[k - 1]) +
                           ")");
    }
  }
  for (const auto& [target, source] : options.derive) {
    trace.Set(target, Differentiate(trace.Column("t"), trace.Column(source)));
  }
  for (const auto& name : options.required) {
    if (!trace.Has(name)) {
      throw InputError(path + ": missing observed column '" + name + "' (header has: " +
                       HeaderSummary(trace.names()) + "; map another header with --column " +
                       name + "=HEADER)");
    }
  }
  if (trace.rows() < 3) {
    throw InputError(path + ": " + std::to_string(trace.rows()) + " sample" +
                     (trace.rows() == 1 ? "" : "s") + " only: a fit needs at least 3");
  }

  FitTrace fit;
  fit.path = path;
  fit.sha256 = std::move(sha256);
  fit.input.kind = InputSignal::Kind::kRecorded;
  fit.input.times = trace.Column("t");
  fit.input.values = trace.Column("u");
  if (trace.Has("open")) fit.input.open = trace.Column("open");
  fit.initial = default_initial;
  if (options.initial_from_trace) {
    if (trace.Has("w")) fit.initial.w = trace.Column("w").front();
    if (trace.Has("theta")) fit.initial.theta = trace.Column("theta").front();
    if (trace.Has("i")) fit.initial.i = trace.Column("i").front();
  }
  fit.trace = std::move(trace);
  return fit;
}

}  // namespace blmd
