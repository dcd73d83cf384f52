// What every command's main() shares: CLI11 parsing with one-line errors, the mapping of
// error channels to exit codes (interface.md), and --version.
#pragma once

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <iostream>
#include <string>

#include "blmd/error.h"
#include "blmd/version.h"

namespace blmd::app {

inline void AddVersionFlag(CLI::App& app, const std::string& tool) {
  app.set_version_flag("--version", tool + " " + kVersion);
}

// Range checks with a readable message ("--threads: must be a whole number >= 0, not -1");
// CLI11's own print the range's ends in full (up to 1.8e308 written out).
inline CLI::Validator NonNegativeWholeNumber() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        // Up to 2^64 - 1 (a seed); no sign, no spaces.
        std::size_t used = 0;
        bool ok = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
        try {
          if (ok) std::stoull(text, &used);
        } catch (const std::exception&) {
          ok = false;
        }
        if (!ok || used != text.size()) return "must be a whole number >= 0, not " + text;
        return {};
      },
      "N>=0");
}
inline CLI::Validator NonNegativeNumber() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::size_t used = 0;
        double value = -1.0;
        try {
          value = std::stod(text, &used);
        } catch (const std::exception&) {
        }
        if (used != text.size() || !(value >= 0.0) || !std::isfinite(value)) {
          return "must be a finite number >= 0, not " + text;
        }
        return {};
      },
      "X>=0");
}
// --threads N: more than the library's cap (src/parallel.h, 256) is capped with a note.
inline int CapThreads(int requested) {
  constexpr int kMax = 256;
  if (requested > kMax) {
    std::cerr << "note: --threads " << requested << " is more than " << kMax << ": using " << kMax
              << "\n";
    return kMax;
  }
  return requested;
}
inline CLI::Validator PositiveNumber() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::size_t used = 0;
        double value = 0.0;
        try {
          value = std::stod(text, &used);
        } catch (const std::exception&) {
        }
        if (used != text.size() || !(value > 0.0) || !std::isfinite(value)) {
          return "must be a number > 0, not " + text;
        }
        return {};
      },
      "X>0");
}

// Parses, then runs `body`. InputError and bad flags -> one line on stderr, exit 2.
inline int Main(CLI::App& app, int argc, char** argv, const std::function<int()>& body) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::cout << app.help("", CLI::AppFormatMode::All);
    return kExitOk;
  } catch (const CLI::CallForVersion&) {
    std::cout << app.version() << "\n";
    return kExitOk;
  } catch (const CLI::ParseError& error) {
    std::cerr << "error: " << InputError::OneLine(error.what()) << " (see " << app.get_name()
              << " --help)\n";
    return kExitBadInput;
  }
  try {
    const int code = body();
    // What went to standard output (the summary, --json) must have arrived: a full disk or
    // a closed pipe is a failure, not a success (issue 18).
    errno = 0;
    std::cout.flush();
    if (!std::cout || std::fflush(stdout) != 0) {
      std::cerr << "error: cannot write to standard output: "
                << (errno ? std::strerror(errno) : "write failed") << "\n";
      return kExitFailed;
    }
    return code;
  } catch (const InputError& error) {
    std::cerr << "error: " << error.what() << "\n";
    return kExitBadInput;
  } catch (const OutputError& error) {
    std::cerr << "error: " << error.what() << "\n";
    return kExitFailed;
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
    return kExitFailed;
  } catch (const std::exception& error) {
    std::cerr << "error: internal: " << InputError::OneLine(error.what()) << "\n";
    return kExitFailed;
  }
}

}  // namespace blmd::app
