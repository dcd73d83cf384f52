// What every command's main() shares: CLI11 parsing with one-line errors, the mapping of
// error channels to exit codes (docs/errors.md), --version, and the --help footer (help.h).
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/version.h"
#include "help.h"

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
// A number for which `accept` holds; otherwise "must be <what>, not TEXT" (the Python
// package's messages).
template <typename Accept>
CLI::Validator NumberValidator(Accept accept, const std::string& what, const std::string& label) {
  return CLI::Validator(
      [accept, what](std::string& text) -> std::string {
        std::size_t used = 0;
        double value = 0.0;
        try {
          value = std::stod(text, &used);
        } catch (const std::exception&) {
        }
        if (used != text.size() || !accept(value)) return "must be " + what + ", not " + text;
        return {};
      },
      label);
}
inline CLI::Validator PositiveNumber() {
  return NumberValidator([](double v) { return v > 0.0 && std::isfinite(v); }, "a number > 0",
                         "X>0");
}
// A share: a number in [0, 1].
inline CLI::Validator ShareNumber() {
  return NumberValidator([](double v) { return v >= 0.0 && v <= 1.0; }, "a number in [0, 1]",
                         "0<=X<=1");
}

// What went to standard output (the summary, --json, --help) must have arrived: a full disk
// or a closed pipe is a failure, not a success. Returns `code`, or kExitFailed
// with one line on stderr.
// `earlier_errno`: the cause of a write that failed before this flush, when the caller knows it
// (PrintAndFinish).
inline int FinishStandardOutput(int code, int earlier_errno = 0) {
  errno = 0;
  std::cout.flush();
  if (std::cout && std::fflush(stdout) == 0 && !std::ferror(stdout)) return code;
  // errno names the cause when this flush failed; a write that failed earlier (a full
  // buffer) may have left it 0.
  const int cause = errno ? errno : earlier_errno;
  std::cerr << "error: cannot write to standard output"
            << (cause ? std::string(": ") + std::strerror(cause) : std::string()) << "\n";
  return kExitFailed;
}

// Prints `text` (--help, --version) and finishes standard output: a text longer than stdout's
// buffer is written before the final flush, so the cause of its failure is taken as it happens.
inline int PrintAndFinish(const std::string& text) {
  errno = 0;
  std::cout << text;
  return FinishStandardOutput(kExitOk, errno);
}

// A flag given an empty value ("--method ''", or "--report=" which CLI11 would read as
// "--report" taking the next argument as its value) is refused, with what the flag expects.
// Flags listed in `checked_in_body` give their own message for '' (it needs the config: the
// valid choices). Throws CLI::ValidationError.
inline std::string EmptyValueMessage(const CLI::App& app, const std::string& flag) {
  const CLI::Option* option = app.get_option_no_throw(flag);
  const std::string what = option ? option->get_description() : std::string();
  return flag + ": empty value" + (what.empty() ? "" : " (expected " + what + ")");
}
inline void RefuseEmptyEquals(const CLI::App& app, int argc, char** argv) {
  for (int k = 1; k < argc; ++k) {
    const std::string arg = argv[k];
    if (arg == "--") break;
    if (arg.size() > 3 && arg.compare(0, 2, "--") == 0 && arg.back() == '=' &&
        arg.find('=') == arg.size() - 1) {
      throw CLI::ValidationError(EmptyValueMessage(app, arg.substr(0, arg.size() - 1)));
    }
  }
}
inline void RefuseEmptyValues(const CLI::App& app,
                              const std::vector<std::string>& checked_in_body) {
  for (const CLI::Option* option : app.get_options()) {
    // An option whose value may be left out (--no-header before --names) checks that itself.
    if (option->count() == 0 || option->get_name().empty() || option->get_expected_min() == 0)
      continue;
    const std::string flag = option->get_name();
    if (std::find(checked_in_body.begin(), checked_in_body.end(), flag) != checked_in_body.end())
      continue;
    for (const std::string& value : option->results()) {
      if (value.empty()) throw CLI::ValidationError(EmptyValueMessage(app, flag));
    }
  }
}

// Parses, then runs `body`. InputError and bad flags -> one line on stderr, exit 2.
inline int Main(CLI::App& app, int argc, char** argv, const std::function<int()>& body,
                const std::vector<std::string>& checked_in_body = {}) {
  try {
    if (app.get_name().empty() && argc > 0) app.name(argv[0]);  // as parse() would
    RefuseEmptyEquals(app, argc, argv);
    app.parse(argc, argv);
    RefuseEmptyValues(app, checked_in_body);
    for (const CLI::App* sub : app.get_subcommands()) RefuseEmptyValues(*sub, checked_in_body);
  } catch (const CLI::CallForHelp&) {
    return PrintAndFinish(app.help());
  } catch (const CLI::CallForAllHelp&) {
    return PrintAndFinish(app.help("", CLI::AppFormatMode::All));
  } catch (const CLI::CallForVersion&) {
    return PrintAndFinish(app.version() + "\n");
  } catch (const CLI::ParseError& error) {
    std::cerr << "error: " << InputError::OneLine(error.what()) << " (see " << app.get_name()
              << " --help)\n";
    return kExitBadInput;
  }
  try {
    return FinishStandardOutput(body());
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
