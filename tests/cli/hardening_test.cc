// Hardening of the identification engine against hostile settings (docs/errors.md §3 and
// §5): method options validated with exit 2 before any work; a fit stuck on a flat
// cost is not called converged; threads capped and a refused thread never aborts; doubles
// from data converted to integers without undefined behaviour.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "blmd/ident/fit/problem.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"
#include "parallel.h"
#include "saturating_cast.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

std::string Ident(const std::string& arguments) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-square.json") +
         " --trace " + SourcePath("testdata/dc-hidden-coulomb.csv") + " " + arguments;
}

// Each bad option: exit 2, exactly this one line on stderr, no report. Before the fix,
// fd_step=0 and fd_step=1e300 crashed (SIGSEGV in ceres::Covariance on a NaN Jacobian),
// walkers=0 ran with one walker, max_iterations=1e12 was an undefined float-to-int cast.
TEST(MethodOptions, OutOfRangeValuesAreExit2WithTheValidRange) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--option fd_step=0", "method ceres: option fd_step=0 must be a number > 0 and <= 0.5"},
      {"--option fd_step=1e300",
       "method ceres: option fd_step=1e300 must be a number > 0 and <= 0.5"},
      {"--option fd_step=nan", "method ceres: option fd_step=nan must be a number > 0 and <= 0.5"},
      {"--option max_iterations=0",
       "method ceres: option max_iterations=0 must be a whole number from 1 to 1000000"},
      {"--option max_iterations=1e12",
       "method ceres: option max_iterations=1e12 must be a whole number from 1 to 1000000"},
      {"--option max_iterations=2.5",
       "method ceres: option max_iterations=2.5 must be a whole number from 1 to 1000000"},
      {"--option function_tolerance=-1",
       "method ceres: option function_tolerance=-1 must be a number > 0 and <= 1"},
      {"--option gradient_tolerance=0",
       "method ceres: option gradient_tolerance=0 must be a number > 0 and <= 1"},
      {"--method fsd --option walkers=0",
       "method fsd: option walkers=0 must be a whole number from 1 to 1024"},
      {"--method fsd --option probes=1e12",
       "method fsd: option probes=1e12 must be a whole number from 2 to 100000"},
      {"--method fsd --option polish=2",
       "method fsd: option polish=2 must be a whole number from 0 to 1"},
      {"--method powell --option algorithm=cobyla",
       "powell option algorithm='cobyla' (valid: bobyqa, praxis)"},
      {"--method powell --option initial_step=0",
       "method powell: option initial_step=0 must be a number > 0 and <= 1"},
      {"--method classic --option tail=2",
       "method classic: option tail=2 must be a number > 0 and <= 1"},
  };
  TempDir dir;
  const std::string report = dir.File("report.json");
  for (const auto& [arguments, message] : cases) {
    SCOPED_TRACE(arguments);
    const CommandResult result = blmd::testing::Run(Ident(arguments + " --report " + report));
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_EQ(result.err, "error: " + message + "\n");
    EXPECT_FALSE(FileExists(report));
  }
}

TEST(MethodOptions, ValidValuesAtTheEndsOfTheRangesRun) {
  const CommandResult result =
      blmd::testing::Run(Ident("--option fd_step=0.5 --option max_iterations=1 --quiet"));
  // One iteration does not converge (exit 1), but it runs: the ends are inside the range.
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(result.err, "error: the fit did not converge: NO_CONVERGENCE\n");
}

// A config whose bounds let the start values be absurd: J a million kg·m² on Ganesh's servo.
std::string WideBoundsConfig(const TempDir& dir) {
  nlohmann::json config = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  config["identification"]["bounds"] = {{"J", {1e-9, 1e9}}, {"B", {1e-12, 1e9}}};
  return dir.Write("wide.json", config.dump(2));
}

// Before the fix: exit 0, "converged (CONVERGENCE)" at J = 1e6 with NRMSE 0.83. The local
// methods themselves still say so ("flat cost", not converged, no interval); the command then
// restarts the fit from the start scan (docs/identification.md §2a), which finds the fit the
// config's own start finds (J = 2.523e-5, NRMSE 0.0514 without the friction the trace has)
// and says in a note that it did.
TEST(FlatCost, AbsurdStartValuesAreNotConverged) {
  TempDir dir;
  const std::string config = WideBoundsConfig(dir);
  const Config wide = LoadConfig(config);
  std::vector<FitTrace> traces;
  traces.push_back(LoadFitTrace(SourcePath("testdata/dc-hidden-coulomb.csv"), TraceInputOptions{},
                                wide.experiment.initial));
  Config absurd = wide;
  absurd.identification.initial.Set("J", 1e8);
  absurd.identification.initial.Set("B", 1e8);
  const FitProblem problem(absurd, traces, {"i", "w"}, MakeFreeParameters(absurd, {"J", "B"}));
  for (const std::string method : {"ceres", "powell"}) {
    SCOPED_TRACE(method);
    const FitResult local = FindOptimizer(method).Minimize(problem, OptimizerOptions{});
    EXPECT_FALSE(local.summary.converged);
    EXPECT_EQ(local.summary.termination, "flat cost");
    EXPECT_FALSE(local.estimates[0].has_interval);
    EXPECT_FALSE(local.estimates[1].has_interval);
    const std::string report = dir.File(method + ".json");
    const CommandResult result =
        blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                           SourcePath("testdata/dc-hidden-coulomb.csv") + " --method " + method +
                           " --initial J=1e8 --initial B=1e8 --quiet --report " + report);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    const nlohmann::json json = nlohmann::json::parse(Slurp(report));
    EXPECT_TRUE(json["fit"]["converged"].get<bool>());
    EXPECT_NEAR(json["parameters"]["J"]["value"].get<double>(), 2.523e-5, 0.001e-5);
    EXPECT_NEAR(json["fit"]["nrmse"].get<double>(), 0.0514, 0.0001);
    EXPECT_EQ(json["parameters"]["J"]["initial"].get<double>(), 1e8);
    ASSERT_TRUE(json.contains("notes"));
    bool noted = false;
    for (const auto& note : json["notes"])
      noted =
          noted || note.get<std::string>().rfind(
                       "the local fit from the config's start stopped in a side valley", 0) == 0;
    EXPECT_TRUE(noted) << json["notes"].dump();
  }
}

// The same wide bounds from good start values: the fit still converges (the check does not
// flag a fit that made progress), and one started at its own optimum is not flat either.
TEST(FlatCost, GoodStartValuesStillConverge) {
  TempDir dir;
  const std::string config = WideBoundsConfig(dir);
  const std::string report = dir.File("report.json");
  CommandResult result = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + config + " --trace " +
      SourcePath("testdata/dc-hidden-coulomb.csv") + " --quiet --report " + report);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json first = nlohmann::json::parse(Slurp(report));
  const double J = first["parameters"]["J"]["value"], B = first["parameters"]["B"]["value"];
  EXPECT_NEAR(J, 2.52315e-05, 1e-9);  // the noise-weighted fit (2.52148e-05 weighted by variance)
  char initial[128];
  std::snprintf(initial, sizeof initial, " --initial J=%.17g --initial B=%.17g", J, B);
  result = blmd::testing::Run(BinPath("blmd-ident") + " --config " + config + " --trace " +
                              SourcePath("testdata/dc-hidden-coulomb.csv") + initial + " --quiet");
  EXPECT_EQ(result.exit_code, 0) << result.err;
}

TEST(Threads, CountIsCappedAndZeroMeansTheMachine) {
  EXPECT_EQ(internal::ThreadCount(40000), internal::kMaxThreads);
  EXPECT_EQ(internal::ThreadCount(3), 3);
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  EXPECT_EQ(internal::ThreadCount(0), hardware > 0 ? std::min(hardware, internal::kMaxThreads) : 1);
}

TEST(Threads, ParallelForRunsEveryItemOnceWhateverTheThreadCount) {
  for (const int threads : {1, 2, 7, 40000}) {
    SCOPED_TRACE(threads);
    std::vector<std::atomic<int>> runs(1000);
    internal::ParallelFor(runs.size(), threads, [&](std::size_t k) { ++runs[k]; });
    for (const auto& count : runs) ASSERT_EQ(count.load(), 1);
  }
}

TEST(Threads, ParallelForRethrowsTheBodysExceptionAfterJoining) {
  std::atomic<int> started{0};
  EXPECT_THROW(internal::ParallelFor(100, 4,
                                     [&](std::size_t k) {
                                       ++started;
                                       if (k == 3) throw std::runtime_error("item 3");
                                     }),
               std::runtime_error);
  EXPECT_GE(started.load(), 4);
}

// The OS refuses threads (here: an address-space limit too small for their stacks). Before
// the fix, std::thread's std::system_error escaped with threads unjoined: std::terminate.
// Now the calling thread (and any that started) does every item. AddressSanitizer reserves
// terabytes of address space, so the limit cannot be applied under it.
#if defined(__SANITIZE_ADDRESS__)
#define BLMD_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define BLMD_ASAN 1
#endif
#endif
#ifndef BLMD_ASAN
// In a child process: limits the address space, then runs ParallelFor with 16 threads asked
// for; exits 0 when every item ran exactly once on fewer threads (the OS refused some).
[[noreturn]] void ParallelForUnderAddressSpaceLimit() {
  // The current address space plus 4 MiB: no room for a thread's 8 MiB stack.
  std::ifstream status("/proc/self/status");
  std::string line;
  long vm_kb = 0;
  while (std::getline(status, line)) {
    if (line.rfind("VmSize:", 0) == 0) vm_kb = std::stol(line.substr(7));
  }
  const rlimit limit = {static_cast<rlim_t>((vm_kb + 4096) * 1024),
                        static_cast<rlim_t>((vm_kb + 4096) * 1024)};
  setrlimit(RLIMIT_AS, &limit);
  // glibc keeps the stacks of finished threads (up to 40 MiB) and reuses them, so a few
  // threads may still start: count the threads that ran items.
  std::mutex mutex;
  std::set<std::thread::id> used;
  std::vector<int> runs(64, 0);
  internal::ParallelFor(runs.size(), 16, [&](std::size_t k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const std::lock_guard<std::mutex> lock(mutex);
    used.insert(std::this_thread::get_id());
    ++runs[k];
  });
  for (int count : runs) {
    if (count != 1) std::_Exit(3);
  }
  std::_Exit(used.size() < 16 ? 0 : 4);
}

#endif

TEST(Threads, RefusedThreadsLeaveTheWorkToTheThreadsThatStarted) {
#ifdef BLMD_ASAN
  GTEST_SKIP() << "RLIMIT_AS cannot be applied under AddressSanitizer";
#else
  EXPECT_EXIT(ParallelForUnderAddressSpaceLimit(), ::testing::ExitedWithCode(0), "");
#endif
}

TEST(SaturatingCast, ClampsOutOfRangeAndNaN) {
  using internal::SaturatingCast;
  EXPECT_EQ(SaturatingCast<int>(1.88e10), std::numeric_limits<int>::max());
  EXPECT_EQ(SaturatingCast<int>(-1e300), std::numeric_limits<int>::lowest());
  EXPECT_EQ(SaturatingCast<int>(std::numeric_limits<double>::infinity()),
            std::numeric_limits<int>::max());
  EXPECT_EQ(SaturatingCast<int>(std::nan(""), -7), -7);
  EXPECT_EQ(SaturatingCast<int>(2147483647.0), std::numeric_limits<int>::max());
  EXPECT_EQ(SaturatingCast<int>(-2.9), -2);
  EXPECT_EQ(SaturatingCast<std::size_t>(-1.0), 0u);
  EXPECT_EQ(SaturatingCast<std::size_t>(1e30), std::numeric_limits<std::size_t>::max());
  EXPECT_EQ(SaturatingCast<std::size_t>(18446744073709551615.0),
            std::numeric_limits<std::size_t>::max());
  EXPECT_EQ(SaturatingCast<long>(12345.99), 12345L);
}

}  // namespace
}  // namespace blmd::testing

namespace blmd::testing {
namespace {

// A config without an experiment section and dt = 5e-4 s, with a trace
// sampled at 10 kHz. Before the fix: exit 2, "sample_rate 10000 Hz is faster than the
// simulation step allows" (the default experiment's rate, which an identification never
// runs). Now the trace's own time base is used (samples between steps interpolated, the
// input's changes stepped to), and the fit matches the one at a fine step.
TEST(TraceTimeBase, ATraceFasterThanTheStepIsFittedNotRefused) {
  TempDir dir;
  nlohmann::json truth = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  truth["experiment"] = {{"input", {{"type", "square"}, {"amplitude", 12.0}, {"period", 0.2}}},
                         {"duration", 0.4},
                         {"sample_rate", 10000}};
  const std::string truth_path = dir.Write("truth.json", truth.dump(2));
  const std::string trace = dir.File("trace.csv");
  CommandResult result =
      blmd::testing::Run(BinPath("blmd-sim") + " --config " + truth_path + " --out " + trace +
                         " --noise i=1% --noise w=1% --quiet");
  ASSERT_EQ(result.exit_code, 0) << result.err;

  nlohmann::json coarse = nlohmann::json::parse(Slurp(SourcePath("configs/ganesh-square.json")));
  coarse.erase("experiment");
  coarse["simulation"] = {{"dt", 5e-4}};
  const std::string coarse_path = dir.Write("coarse.json", coarse.dump(2));
  const std::string report = dir.File("report.json");
  result = blmd::testing::Run(BinPath("blmd-ident") + " --config " + coarse_path + " --trace " +
                              trace + " --quiet --report " + report);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json json = nlohmann::json::parse(Slurp(report));
  EXPECT_NEAR(json["parameters"]["J"]["value"].get<double>() / 2.26e-5, 1.0, 0.005);
  EXPECT_NEAR(json["parameters"]["B"]["value"].get<double>() / 2.261e-5, 1.0, 0.01);

  // blmd-sim runs that config's (default) experiment: there the check still applies.
  result = blmd::testing::Run(BinPath("blmd-sim") + " --config " + coarse_path + " --out " +
                              dir.File("never.csv"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.err, "error: " + coarse_path +
                            ": sample_rate 10000 Hz is faster than the simulation step allows "
                            "(1/dt = 2000 Hz); lower it or reduce dt\n");
  EXPECT_FALSE(FileExists(dir.File("never.csv")));
}

}  // namespace
}  // namespace blmd::testing

#include <glog/logging.h>

#include "blmd/ident/fit/trace_input.h"
#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/io/config.h"

namespace blmd::testing {
namespace {

// Ceres's glog lines must not precede a command's one-line error. After a
// ceres fit that is not verbose, nothing below FATAL reaches stderr; with --verbose it does.
// (Before the fix glog's default printed WARNING and above, with a "Logging before
// InitGoogleLogging()" line first.)
TEST(CeresLog, SilentUnlessVerbose) {
  const Config config = LoadConfig(SourcePath("configs/ganesh-square.json"));
  TraceInputOptions input;
  input.required = {"i", "w"};
  std::vector<FitTrace> traces;
  traces.push_back(
      LoadFitTrace(SourcePath("testdata/dc-hidden-coulomb.csv"), input, config.experiment.initial));
  const FitProblem problem(config, std::move(traces), {"i", "w"},
                           MakeFreeParameters(config, {"J", "B"}));
  OptimizerOptions options;
  for (const bool verbose : {false, true}) {
    SCOPED_TRACE(verbose);
    options.verbose = verbose;
    EXPECT_TRUE(FindOptimizer("ceres").Minimize(problem, options).summary.converged);
    ::testing::internal::CaptureStderr();
    LOG(WARNING) << "a Ceres-style warning";
    const std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(err.find("a Ceres-style warning") != std::string::npos, verbose) << err;
  }
}

}  // namespace
}  // namespace blmd::testing
