#include "blmd/io/files.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "blmd/error.h"
#include "io/readable_file.h"

namespace blmd {
namespace {

// Pending temporary files, removed by the signal handler. Fixed-size and lock-free so the
// handler only calls async-signal-safe functions (unlink, _exit).
constexpr int kMaxPending = 64;
// The signals that end a run and remove its temporaries (a closed terminal sends SIGHUP,
// Ctrl-\ SIGQUIT).
constexpr int kCleanupSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
std::array<std::atomic<const char*>, kMaxPending> g_pending{};

void OnSignal(int signal_number) {
  for (auto& slot : g_pending) {
    const char* name = slot.load();
    if (name) unlink(name);
  }
  _exit(128 + signal_number);
}

int Register(const char* name) {
  for (int k = 0; k < kMaxPending; ++k) {
    const char* expected = nullptr;
    if (g_pending[k].compare_exchange_strong(expected, name)) return k;
  }
  return -1;
}

void Unregister(int slot) {
  if (slot >= 0) g_pending[slot].store(nullptr);
}

std::string Folder(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

}  // namespace

std::string ReadFileText(const std::string& path, std::size_t max_bytes, const std::string& what) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot read: " + std::strerror(errno));
  struct stat info {};
  if (fstat(fd, &info) != 0 || S_ISDIR(info.st_mode)) {
    const int saved = S_ISDIR(info.st_mode) ? EISDIR : errno;
    close(fd);
    throw InputError(path + ": cannot read: " + std::strerror(saved));
  }
  std::string text;
  if (S_ISREG(info.st_mode) && static_cast<std::size_t>(info.st_size) > max_bytes) {
    close(fd);
    throw InputError(path + ": larger than " + std::to_string(max_bytes >> 20) + " MiB: not a " +
                     what);
  }
  if (S_ISREG(info.st_mode) && info.st_size > 0)
    text.reserve(static_cast<std::size_t>(info.st_size));
  char chunk[1 << 16];
  while (true) {
    const ssize_t n = read(fd, chunk, sizeof chunk);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      const int saved = errno;
      close(fd);
      throw InputError(path + ": cannot read: " + std::strerror(saved));
    }
    text.append(chunk, static_cast<std::size_t>(n));
    if (text.size() > max_bytes) {
      close(fd);
      throw InputError(path + ": larger than " + std::to_string(max_bytes >> 20) + " MiB: not a " +
                       what);
    }
  }
  close(fd);
  return text;
}

void InstallCleanupOnSignal() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction action {};
    action.sa_handler = OnSignal;
    sigemptyset(&action.sa_mask);
    for (const int signal_number : kCleanupSignals) sigaction(signal_number, &action, nullptr);
  });
}

void CheckWritable(const std::string& path) {
  struct stat info {};
  if (stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode)) {
    throw InputError(path + ": cannot write: " + std::strerror(EISDIR));
  }
  const std::string folder = Folder(path);
  int error = 0;
  // NOLINTNEXTLINE(bugprone-branch-clone): errno of two different calls
  if (stat(folder.c_str(), &info) != 0) {
    error = errno;
  } else if (!S_ISDIR(info.st_mode)) {
    error = ENOTDIR;
  } else if (access(folder.c_str(), W_OK | X_OK) != 0) {
    error = errno;
  }
  if (error != 0) {
    throw InputError(path + ": cannot write in folder '" + folder + "': " + std::strerror(error));
  }
}

namespace {

// Writes `content` to an existing file that is not a regular one (a FIFO, a terminal, a
// character device) in place, checking every write and the close.
void WriteInPlace(const std::string& path, const std::string& content) {
  const int fd = open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) throw OutputError(path + ": cannot write: open: " + std::strerror(errno));
  std::size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = write(fd, content.data() + written, content.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int saved = errno;
      close(fd);
      throw OutputError(path + ": cannot write: write: " + std::strerror(saved));
    }
    written += static_cast<std::size_t>(n);
  }
  if (close(fd) != 0) throw OutputError(path + ": cannot write: close: " + std::strerror(errno));
}

}  // namespace

void CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  auto same = [](const std::string& a, const std::string& b) {
    struct stat sa {
    }, sb{};
    return stat(a.c_str(), &sa) == 0 && stat(b.c_str(), &sb) == 0 && S_ISREG(sa.st_mode) &&
           sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  };
  for (std::size_t k = 0; k < outputs.size(); ++k) {
    const NamedPath& out = outputs[k];
    if (out.path.empty()) continue;
    CheckWritable(out.path);
    for (const NamedPath& in : inputs) {
      if (!in.path.empty() && same(out.path, in.path)) {
        throw InputError(out.flag + " " + out.path + " is the " + in.flag +
                         " input: writing it would destroy the input; choose another output file");
      }
    }
    for (std::size_t m = 0; m < k; ++m) {
      struct stat info {};
      const bool device = stat(out.path.c_str(), &info) == 0 && !S_ISREG(info.st_mode);
      if (!outputs[m].path.empty() && !device &&
          (outputs[m].path == out.path || same(outputs[m].path, out.path))) {
        throw InputError(out.flag + " " + out.path + " is also " + outputs[m].flag +
                         ": give each output its own file");
      }
    }
  }
}

namespace {

// Where a write to `path` lands: `path` itself, or, when it is a symbolic link, the file the
// link names (followed like the shell's `>` does: the link is kept, its target replaced),
// even when that file does not exist yet.
std::string LinkTarget(const std::string& path) {
  std::string current = path;
  for (int hop = 0; hop < 40; ++hop) {  // Linux's own limit (MAXSYMLINKS)
    struct stat link {};
    if (lstat(current.c_str(), &link) != 0 || !S_ISLNK(link.st_mode)) return current;
    std::vector<char> target(static_cast<std::size_t>(link.st_size > 0 ? link.st_size : 255) + 1);
    const ssize_t n = readlink(current.c_str(), target.data(), target.size());
    if (n < 0 || static_cast<std::size_t>(n) >= target.size()) {
      throw OutputError(path + ": cannot write: cannot read the symbolic link '" + current + "'");
    }
    const std::string next(target.data(), static_cast<std::size_t>(n));
    const auto slash = current.rfind('/');
    current = next.front() == '/' || slash == std::string::npos
                  ? next
                  : current.substr(0, slash + 1) + next;
  }
  throw OutputError(path + ": cannot write: " + std::strerror(ELOOP));
}

}  // namespace

void WriteFileAtomically(const std::string& link_or_path, const std::string& content) {
  const std::string path = LinkTarget(link_or_path);
  struct stat existing {};
  if (stat(path.c_str(), &existing) == 0 && !S_ISREG(existing.st_mode) &&
      !S_ISDIR(existing.st_mode)) {
    WriteInPlace(path, content);  // never replace a device node or a FIFO with a file
    return;
  }
  InstallCleanupOnSignal();
  std::string temp = path + ".tmp.XXXXXX";
  std::vector<char> name(temp.begin(), temp.end());
  name.push_back('\0');
  // SIGINT/SIGTERM are held between creating the temporary and registering it, so that the
  // handler never misses one (it would be left behind).
  sigset_t held, previous;
  sigemptyset(&held);
  for (const int signal_number : kCleanupSignals) sigaddset(&held, signal_number);
  pthread_sigmask(SIG_BLOCK, &held, &previous);
  const int fd = mkstemp(name.data());
  const int saved_errno = errno;
  const int slot = fd < 0 ? -1 : Register(name.data());
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (fd < 0) {
    throw InputError(path + ": cannot write in folder '" + Folder(path) +
                     "': " + std::strerror(saved_errno));
  }
  auto fail = [&](const std::string& what) {
    const int saved = errno;
    close(fd);
    unlink(name.data());
    Unregister(slot);
    throw OutputError(path + ": cannot write: " + what + ": " + std::strerror(saved));
  };
  std::size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = write(fd, content.data() + written, content.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write");
    }
    written += static_cast<std::size_t>(n);
  }
  if (fchmod(fd, 0644) != 0) fail("chmod");
  if (fsync(fd) != 0) fail("fsync");
  if (close(fd) != 0) {
    unlink(name.data());
    Unregister(slot);
    throw OutputError(path + ": cannot write: close: " + std::strerror(errno));
  }
  if (rename(name.data(), path.c_str()) != 0) {
    const int saved = errno;
    unlink(name.data());
    Unregister(slot);
    throw OutputError(path + ": cannot write: rename: " + std::strerror(saved));
  }
  Unregister(slot);
}

// SHA-256 by OpenSSL's EVP interface (libcrypto; it uses the x86 SHA extensions where the
// CPU has them).
Sha256::Sha256() : context_(EVP_MD_CTX_new()) {
  if (context_ == nullptr || EVP_DigestInit_ex(context_, EVP_sha256(), nullptr) != 1) {
    EVP_MD_CTX_free(context_);
    throw std::runtime_error("SHA-256: OpenSSL could not start a digest");
  }
}

Sha256::~Sha256() { EVP_MD_CTX_free(context_); }

void Sha256::Update(std::string_view bytes) {
  if (EVP_DigestUpdate(context_, bytes.data(), bytes.size()) != 1) {
    throw std::runtime_error("SHA-256: OpenSSL digest update failed");
  }
}

std::string Sha256::HexDigest() {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(context_, digest, &length) != 1 || length != 32) {
    throw std::runtime_error("SHA-256: OpenSSL digest failed");
  }
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(64);
  for (unsigned int k = 0; k < length; ++k) {
    out += hex[digest[k] >> 4];
    out += hex[digest[k] & 0xf];
  }
  return out;
}

std::string Sha256Hex(const std::string& bytes) {
  Sha256 sha;
  sha.Update(bytes);
  return sha.HexDigest();
}

std::string Sha256OfFile(const std::string& path) {
  const internal::ReadableFile file(path);
  Sha256 hash;
  std::vector<char> buffer(std::size_t{1} << 20);
  while (const std::size_t n = file.ReadSome(buffer.data(), buffer.size())) {
    hash.Update(std::string_view(buffer.data(), n));
  }
  return hash.HexDigest();
}

}  // namespace blmd
