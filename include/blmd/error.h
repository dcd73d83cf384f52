// Error channels (docs/errors.md):
//  - InputError: the user's input (file, flag, config) is wrong. Thrown by the I/O layer,
//    caught in main(), printed as one line, exit code 2, nothing written.
//  - Broken invariants inside the library abort (assert / std::logic_error).
//  - How a simulation or an optimiser ended is a status value, never an exception.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace blmd {

// One clear line: "<where>: <what>", where = "file:line:column" (line/column when known).
// Control characters (a newline in a file name, a NUL in a JSON key) are shown as \xNN, so
// the message is always one printable line.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(OneLine(message)) {}
  InputError(const std::string& file, long line, long column, const std::string& message)
      : std::runtime_error(OneLine(Format(file, line, column, message))) {}

  static std::string Format(const std::string& file, long line, long column,
                            const std::string& message);
  // `text` with its control characters (bytes below 0x20, and 0x7f) written as \xNN.
  static std::string OneLine(const std::string& text);
  // At most `max` bytes of a name or value from the input, then "..." (a misspelt key a
  // megabyte long must not become a megabyte-long message).
  static std::string Excerpt(const std::string& text, std::size_t max = 80) {
    return text.size() <= max ? text : text.substr(0, max) + "...";
  }
};

// An output the work produced could not be written (a full disk, a device that refuses the
// bytes, standard output closed): the work was done, its result is lost. Exit code 1.
class OutputError : public std::runtime_error {
 public:
  explicit OutputError(const std::string& message)
      : std::runtime_error(InputError::OneLine(message)) {}
};

// Exit codes of every command (docs/errors.md §1).
enum ExitCode : int {
  kExitOk = 0,
  kExitFailed = 1,    // the work failed: a diverged simulation, a fit that did not converge
  kExitBadInput = 2,  // bad usage or bad input; nothing written
  kExitGate = 3,      // a gate such as --fail-above-nrmse was not met
};

}  // namespace blmd
