// Trace CSV reading at scale: a 5-million-row trace t,u,i,w (the numbers written as
// blmd-sim writes them, shortest round-trip form) is read with ReadTraceCsv. Counters:
// `MB_per_s` of CSV text, `peak_rss_MB` (the process's peak resident memory during the read
// above its resident memory before it), `numeric_MB` (rows x columns x 8 bytes) and
// `memory_ratio` = peak_rss_MB / numeric_MB. Targets: at least 100 MB/s and a
// ratio under 3.
//
// The file is generated once into /tmp (about 270 MB; BLMD_IO_BENCH_FILE overrides the path)
// and kept for later runs. The peak is measured by resetting the kernel's high-water mark
// (/proc/self/clear_refs, "5") before each read and reading VmHWM after it.
//
//   build/bin/blmd_bench --benchmark_filter=BM_ReadTraceCsv --benchmark_repetitions=3
#include <benchmark/benchmark.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>

#include "blmd/io/csv.h"
#include "blmd/io/files.h"

namespace {

constexpr long kRows = 5'000'000;
constexpr int kColumns = 4;

std::string BenchFile() {
  const char* path = std::getenv("BLMD_IO_BENCH_FILE");
  return path ? path : "/tmp/blmd-io-bench-5M.csv";
}

// Writes the trace in 1 MB pieces (the generator itself stays small): a 10 kHz 24 V square
// wave and a current and speed with full-precision values.
void Generate(const std::string& path) {
  const std::string temporary = path + ".part";
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file) throw std::runtime_error("cannot write " + temporary);
  std::string chunk = "# blmd io_bench: 5e6 rows\nt,u,i,w\n";
  for (long k = 0; k < kRows; ++k) {
    const double t = static_cast<double>(k) * 1e-4;
    const double u = (k / 5000) % 2 ? -24.0 : 24.0;
    const double i = 1.9 * std::sin(2.0 * std::numbers::pi * 3.0 * t) +
                     1e-3 * std::cos(0.37 * static_cast<double>(k));
    const double w = 420.0 * (1.0 - std::exp(-t)) * std::cos(2.0 * std::numbers::pi * 0.5 * t);
    chunk += blmd::FormatNumber(t);
    chunk += ',';
    chunk += blmd::FormatNumber(u);
    chunk += ',';
    chunk += blmd::FormatNumber(i);
    chunk += ',';
    chunk += blmd::FormatNumber(w);
    chunk += '\n';
    if (chunk.size() > (1 << 20)) {
      std::fwrite(chunk.data(), 1, chunk.size(), file);
      chunk.clear();
    }
  }
  std::fwrite(chunk.data(), 1, chunk.size(), file);
  std::fclose(file);
  std::rename(temporary.c_str(), path.c_str());
}

// kB from /proc/self/status ("VmHWM:", "VmRSS:"), -1 when unknown.
long StatusKb(const std::string& key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) return std::atol(line.c_str() + key.size());
  }
  return -1;
}

bool ResetPeak() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

void BM_ReadTraceCsv5M(benchmark::State& state) {
  const std::string path = BenchFile();
  struct stat info {};
  if (stat(path.c_str(), &info) != 0) {
    Generate(path);
    stat(path.c_str(), &info);
  }
  const double megabytes = static_cast<double>(info.st_size) / 1e6;
  blmd::CsvReadOptions options;
  options.required = {"t", "u", "i", "w"};
  double peak_mb = 0.0;
  bool peak_known = true;
  for (auto _ : state) {
    state.PauseTiming();
    peak_known = peak_known && ResetPeak();
    const long before = StatusKb("VmRSS:");
    state.ResumeTiming();
    blmd::Trace trace = blmd::ReadTraceCsv(path, options);
    benchmark::DoNotOptimize(trace.Column("w").data());
    state.PauseTiming();
    if (trace.rows() != static_cast<std::size_t>(kRows)) state.SkipWithError("wrong row count");
    const long peak = StatusKb("VmHWM:");
    peak_mb = std::max(peak_mb, static_cast<double>(peak - before) * 1024.0 / 1e6);
    trace = blmd::Trace();  // freed outside the timing
    state.ResumeTiming();
  }
  const double numeric_mb = static_cast<double>(kRows) * kColumns * 8.0 / 1e6;
  state.counters["file_MB"] = megabytes;
  state.counters["MB_per_s"] =
      benchmark::Counter(megabytes, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["numeric_MB"] = numeric_mb;
  if (peak_known) {
    state.counters["peak_rss_MB"] = peak_mb;
    state.counters["memory_ratio"] = peak_mb / numeric_mb;
  } else {
    state.SetLabel("peak RSS unknown: /proc/self/clear_refs not writable");
  }
}
BENCHMARK(BM_ReadTraceCsv5M)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
