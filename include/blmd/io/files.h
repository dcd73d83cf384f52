// File helpers: whole-file reads with clear errors, atomic writes, content hashes.
#pragma once

#include <string>

namespace blmd {

// Throws InputError("<path>: cannot read: <reason>").
std::string ReadFileText(const std::string& path);

// Writes `content` to a temporary file beside `path`, flushes it to disk and renames it
// over `path`: readers see the old file or the complete new one, never a part. The
// temporary is removed on failure and, through a signal handler, on SIGINT/SIGTERM.
// Throws InputError when the folder cannot be written.
void WriteFileAtomically(const std::string& path, const std::string& content);

// Installs the SIGINT/SIGTERM handler that removes pending temporaries (idempotent).
void InstallCleanupOnSignal();

// Lower-case hex SHA-256 of a byte string.
std::string Sha256Hex(const std::string& bytes);

}  // namespace blmd
