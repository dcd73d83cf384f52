// File helpers: whole-file reads with clear errors, atomic writes, content hashes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

struct evp_md_ctx_st;  // OpenSSL (openssl/types.h): EVP_MD_CTX

namespace blmd {

// Throws InputError("<path>: cannot read: <reason>"), also for a folder. At most
// `max_bytes` are read: a larger file (or a device such as /dev/zero that never ends) is
// InputError("<path>: larger than <N> MiB: not a <what>").
std::string ReadFileText(const std::string& path,
                         std::size_t max_bytes = std::numeric_limits<std::size_t>::max(),
                         const std::string& what = "text file");

// The most bytes a config is read (16 MiB; the largest bundled one is 2 KiB).
inline constexpr std::size_t kMaxConfigBytes = std::size_t{16} << 20;

// One output named by a flag, for CheckOutputs.
struct NamedPath {
  std::string flag;  // "--report"
  std::string path;
};
// Checks, before any work, every output of a command: each can be written (CheckWritable),
// none is one of the inputs (the same file, by device and inode, following links: writing
// it would destroy the input) and no two outputs are the same file. InputError otherwise:
// "--out trace.csv is the --trace input: choose another output file".
void CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

// Writes `content` to a temporary file beside `path`, flushes it to disk and renames it
// over `path`: readers see the old file or the complete new one, never a part. The
// temporary is removed on failure and, through a signal handler, on SIGINT, SIGTERM,
// SIGHUP and SIGQUIT. When `path` exists and is not a regular file (a FIFO, a terminal,
// /dev/null, /dev/stdout) it is written in place: a device node is never replaced by a
// file. Throws InputError when the folder cannot be written, OutputError when a write,
// fsync, close or rename fails (a full disk: /dev/full).
void WriteFileAtomically(const std::string& path, const std::string& content);

// Checks, before long work, that `path` can be written later: its folder exists and is
// writable and `path` is not a folder. Throws InputError with the same message the write
// would give ("<path>: cannot write in folder '<folder>': <reason>").
void CheckWritable(const std::string& path);

// Installs the SIGINT/SIGTERM handler that removes pending temporaries (idempotent).
void InstallCleanupOnSignal();

// Lower-case hex SHA-256 of a byte string.
std::string Sha256Hex(const std::string& bytes);
// Lower-case hex SHA-256 of a file's bytes, read in pieces. Throws InputError("<path>: cannot
// read: <reason>"), also for a folder.
std::string Sha256OfFile(const std::string& path);

// SHA-256 (FIPS 180-4) fed in pieces, for files read in chunks; OpenSSL's libcrypto computes
// it (a Debian package; it uses the x86 SHA extensions where the CPU has them).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(std::string_view bytes);
  // Lower-case hex digest of everything fed; the object is spent afterwards.
  std::string HexDigest();

 private:
  evp_md_ctx_st* context_;  // OpenSSL's EVP_MD_CTX
};

}  // namespace blmd
