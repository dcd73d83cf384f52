// Output safety (interface.md, docs/errors.md §5): every output is written to a temporary
// file beside it and renamed, and SIGINT/SIGTERM remove a pending temporary, so an
// interrupted run leaves the old file or none, never a part, and no "*.tmp.*" behind.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "blmd/io/files.h"
#include "support/test_support.h"

extern char** environ;

namespace blmd::testing {
namespace {

std::vector<std::string> Temporaries(const std::string& folder) {
  std::vector<std::string> found;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.find(".tmp.") != std::string::npos) found.push_back(name);
  }
  return found;
}

// Waits up to `seconds` for `pid`; returns its wait status, or -1 if it is still running.
int WaitFor(pid_t pid, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return -1;
}

// A long BLMD sweep (800 points of ~15 ms each on one thread) is interrupted after 0.5 s:
// the output path keeps its old content and no temporary is left.
void InterruptSweep(int signal_number) {
  TempDir dir;
  const std::string out = dir.Write("surface.csv", "old surface\n");
  const std::string svg = dir.Write("surface.svg", "<svg>old</svg>\n");
  const std::vector<std::string> arguments = {BinPath("blmd-surface"),
                                              "--config",
                                              SourcePath("configs/blmd-d31x.json"),
                                              "--trace",
                                              SourcePath("testdata/blmd-d31x-step.csv"),
                                              "--grid",
                                              "J=6e-4:2.4e-3:40",
                                              "--grid",
                                              "B=1e-5:5e-3:20",
                                              "--threads",
                                              "1",
                                              "--quiet",
                                              "--out",
                                              out,
                                              "--svg",
                                              svg};
  std::vector<char*> argv;
  for (const auto& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, dir.File("stderr").c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(WaitFor(pid, 0.0), -1)
      << "the sweep ended before it was interrupted: " << Slurp(dir.File("stderr"));
  ASSERT_EQ(kill(pid, signal_number), 0);
  const int status = WaitFor(pid, 20.0);
  ASSERT_NE(status, -1) << "still running 20 s after the signal";
  // Ended by the signal: through the cleanup handler (exit 128 + signal) or the default
  // action; never a normal exit.
  const bool by_handler = WIFEXITED(status) && WEXITSTATUS(status) == 128 + signal_number;
  const bool by_default = WIFSIGNALED(status) && WTERMSIG(status) == signal_number;
  EXPECT_TRUE(by_handler || by_default) << "wait status " << status;
  EXPECT_EQ(Slurp(out), "old surface\n");
  EXPECT_EQ(Slurp(svg), "<svg>old</svg>\n");
  EXPECT_EQ(Temporaries(dir.path()), std::vector<std::string>{});
}

TEST(OutputSafety, SigintDuringASweepKeepsTheOldOutput) { InterruptSweep(SIGINT); }
TEST(OutputSafety, SigtermDuringASweepKeepsTheOldOutput) { InterruptSweep(SIGTERM); }
TEST(OutputSafety, SighupDuringASweepKeepsTheOldOutput) { InterruptSweep(SIGHUP); }
TEST(OutputSafety, SigquitDuringASweepKeepsTheOldOutput) { InterruptSweep(SIGQUIT); }

// An output that cannot be written is found before the work, not after it: a sweep of
// 800 BLMD points (about 12 s) with a missing output folder fails at once.
TEST(OutputSafety, AnUnwritableOutputIsReportedBeforeTheWork) {
  TempDir dir;
  const std::string sweep = BinPath("blmd-surface") + " --config " +
                            SourcePath("configs/blmd-d31x.json") + " --trace " +
                            SourcePath("testdata/blmd-d31x-step.csv") +
                            " --grid J=6e-4:2.4e-3:40 --grid B=1e-5:5e-3:20 --threads 1 --quiet";
  const auto started = std::chrono::steady_clock::now();
  CommandResult run = blmd::testing::Run(sweep + " --out " + dir.File("missing/surface.csv"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "error: " + dir.File("missing/surface.csv") + ": cannot write in folder '" +
                         dir.File("missing") + "': No such file or directory\n");
  run = blmd::testing::Run(sweep + " --out " + dir.File("s.csv") + " --svg " + dir.path());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "error: " + dir.path() + ": cannot write: Is a directory\n");
  run = blmd::testing::Run(
      BinPath("blmd-ident") + " --config " + SourcePath("configs/blmd-d31x.json") + " --trace " +
      SourcePath("testdata/blmd-d31x-step.csv") + " --report " + dir.File("missing/report.json"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "error: " + dir.File("missing/report.json") + ": cannot write in folder '" +
                         dir.File("missing") + "': No such file or directory\n");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_LT(seconds, 6.0);  // three starts, no sweep and no fit
  EXPECT_EQ(Temporaries(dir.path()), std::vector<std::string>{});
}

// The write itself interrupted: a child rewrites a 16 MB file in a loop and is killed
// the moment a temporary is seen beside it (so the signal lands while writing, syncing or
// renaming). Afterwards the file is the old content or the whole new one, and the signal
// handler has removed the temporary.
TEST(OutputSafety, SignalDuringTheWriteLeavesOldOrCompleteNewAndNoTemporary) {
  const std::string fresh(16 << 20, 'n');
  int seen_partial_window = 0;
  for (int round = 0; round < 12; ++round) {
    TempDir dir;
    const std::string path = dir.Write("out.csv", "old\n");
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        while (true) WriteFileAtomically(path, fresh);  // until killed
      } catch (...) {
        _exit(99);  // never return into the test runner
      }
    }
    bool temporary_seen = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!temporary_seen && std::chrono::steady_clock::now() < deadline) {
      temporary_seen = !Temporaries(dir.path()).empty();
    }
    // SIGHUP (a closed terminal) and SIGQUIT (Ctrl-\\) too: before the fix they left the
    // temporary behind (their default actions end the process without the handler).
    const int signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
    const int signal_number = signals[round % 4];
    kill(child, signal_number);
    const int status = WaitFor(child, 20.0);
    ASSERT_NE(status, -1);
    seen_partial_window += temporary_seen;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 128 + signal_number) << status;
    const std::string content = Slurp(path);
    EXPECT_TRUE(content == "old\n" || content == fresh) << content.size() << " bytes";
    EXPECT_EQ(Temporaries(dir.path()), std::vector<std::string>{});
  }
  EXPECT_GT(seen_partial_window, 0);  // the signal did land while a temporary existed
}

}  // namespace
}  // namespace blmd::testing
