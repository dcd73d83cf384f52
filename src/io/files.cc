#include "blmd/io/files.h"

#include <fcntl.h>
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
#include <vector>

#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "blmd/error.h"

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

// FIPS 180-4 SHA-256.
namespace {
constexpr std::uint32_t kSha256Round[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

#if defined(__x86_64__)
// The same compression with the x86 SHA extensions (Intel SHA-NI, AMD since Zen), for CPUs
// that have them: about a tenth of the software rounds' instructions. The state is kept as
// ABEF and CDGH, as SHA256RNDS2 wants it; each group of 4 rounds adds its 4 message words
// and constants and runs two double rounds; message words 16..63 come from SHA256MSG1/MSG2.
[[gnu::target("sha,sse4.1,ssse3")]] void Sha256BlocksShaNi(std::uint32_t* state,
                                                           const unsigned char* data,
                                                           std::size_t blocks) {
  const __m128i byte_swap = _mm_set_epi64x(0x0c0d0e0f08090a0bLL, 0x0405060700010203LL);
  __m128i dcba = _mm_loadu_si128(reinterpret_cast<const __m128i*>(state));
  __m128i hgfe = _mm_loadu_si128(reinterpret_cast<const __m128i*>(state + 4));
  const __m128i cdab = _mm_shuffle_epi32(dcba, 0xB1);
  const __m128i efgh = _mm_shuffle_epi32(hgfe, 0x1B);
  __m128i abef = _mm_alignr_epi8(cdab, efgh, 8);
  __m128i cdgh = _mm_blend_epi16(efgh, cdab, 0xF0);
  for (; blocks > 0; --blocks, data += 64) {
    const __m128i abef_saved = abef, cdgh_saved = cdgh;
    __m128i words[4];  // W[4g .. 4g+3] of the last four groups, by g mod 4
    for (int g = 0; g < 16; ++g) {
      __m128i& w = words[g % 4];
      if (g < 4) {
        w = _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(data + 16 * g)),
                             byte_swap);
      } else {
        // W[t..t+3] (t = 4g) from W[t-16..t-13] (w), W[t-12..t-9], W[t-7..t-4], W[t-4..t-1].
        const __m128i& w12 = words[(g + 1) % 4];
        const __m128i& w8 = words[(g + 2) % 4];
        const __m128i& w4 = words[(g + 3) % 4];
        const __m128i sum = _mm_add_epi32(_mm_sha256msg1_epu32(w, w12), _mm_alignr_epi8(w4, w8, 4));
        w = _mm_sha256msg2_epu32(sum, w4);
      }
      __m128i message =
          _mm_add_epi32(w, _mm_loadu_si128(reinterpret_cast<const __m128i*>(kSha256Round + 4 * g)));
      cdgh = _mm_sha256rnds2_epu32(cdgh, abef, message);
      message = _mm_shuffle_epi32(message, 0x0E);
      abef = _mm_sha256rnds2_epu32(abef, cdgh, message);
    }
    abef = _mm_add_epi32(abef, abef_saved);
    cdgh = _mm_add_epi32(cdgh, cdgh_saved);
  }
  const __m128i feba = _mm_shuffle_epi32(abef, 0x1B);
  const __m128i dchg = _mm_shuffle_epi32(cdgh, 0xB1);
  dcba = _mm_blend_epi16(feba, dchg, 0xF0);
  hgfe = _mm_alignr_epi8(dchg, feba, 8);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(state), dcba);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(state + 4), hgfe);
}

bool CpuHasShaNi() {
  // CPUID leaf 7 EBX bit 29: SHA; leaf 1 ECX bit 19: SSE4.1 (clang-14 has no
  // __builtin_cpu_supports("sha")).
  static const bool has = [] {
    unsigned a = 0, b = 0, c = 0, d = 0;
    if (!__get_cpuid(1, &a, &b, &c, &d) || !(c & (1u << 19))) return false;
    return __get_cpuid_count(7, 0, &a, &b, &c, &d) && (b & (1u << 29)) != 0;
  }();
  return has;
}
#endif

std::atomic<bool> g_sha_hardware_allowed{true};
}  // namespace

bool Sha256::UseHardware(bool allowed) {
  g_sha_hardware_allowed = allowed;
#if defined(__x86_64__)
  return allowed && CpuHasShaNi();
#else
  return false;
#endif
}

void Sha256::Blocks(const unsigned char* p, std::size_t blocks) {
#if defined(__x86_64__)
  if (g_sha_hardware_allowed.load(std::memory_order_relaxed) && CpuHasShaNi()) {
    Sha256BlocksShaNi(state_.data(), p, blocks);
    return;
  }
#endif
  for (; blocks > 0; --blocks, p += 64) Block(p);
}

Sha256::Sha256()
    : state_{0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
             0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19} {}

void Sha256::Block(const unsigned char* p) {
  auto rotr = [](std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); };
  std::uint32_t w[64];
  for (int t = 0; t < 16; ++t) {
    w[t] = (std::uint32_t(p[4 * t]) << 24) | (std::uint32_t(p[4 * t + 1]) << 16) |
           (std::uint32_t(p[4 * t + 2]) << 8) | std::uint32_t(p[4 * t + 3]);
  }
  for (int t = 16; t < 64; ++t) {
    const std::uint32_t s0 = rotr(w[t - 15], 7) ^ rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
    const std::uint32_t s1 = rotr(w[t - 2], 17) ^ rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
    w[t] = w[t - 16] + s0 + w[t - 7] + s1;
  }
  std::uint32_t a = state_[0], b = state_[1], c = state_[2], d = state_[3], e = state_[4],
                f = state_[5], g = state_[6], h = state_[7];
  for (int t = 0; t < 64; ++t) {
    const std::uint32_t S1 = rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25);
    const std::uint32_t ch = (e & f) ^ (~e & g);
    const std::uint32_t temp1 = h + S1 + ch + kSha256Round[t] + w[t];
    const std::uint32_t S0 = rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22);
    const std::uint32_t maj = (a & b) ^ (a & c) ^ (b & c);
    const std::uint32_t temp2 = S0 + maj;
    h = g;
    g = f;
    f = e;
    e = d + temp1;
    d = c;
    c = b;
    b = a;
    a = temp1 + temp2;
  }
  state_[0] += a;
  state_[1] += b;
  state_[2] += c;
  state_[3] += d;
  state_[4] += e;
  state_[5] += f;
  state_[6] += g;
  state_[7] += h;
}

void Sha256::Update(std::string_view bytes) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  std::size_t n = bytes.size();
  length_ += n;
  if (buffered_ > 0) {
    const std::size_t take = std::min(n, 64 - buffered_);
    std::memcpy(buffer_.data() + buffered_, p, take);
    buffered_ += take;
    p += take;
    n -= take;
    if (buffered_ < 64) return;
    Blocks(buffer_.data(), 1);
    buffered_ = 0;
  }
  Blocks(p, n / 64);
  p += 64 * (n / 64);
  n %= 64;
  std::memcpy(buffer_.data(), p, n);
  buffered_ = n;
}

std::string Sha256::HexDigest() {
  const std::uint64_t bit_length = length_ * 8;
  unsigned char tail[72] = {0x80};
  const std::size_t pad = (buffered_ < 56 ? 56 : 120) - buffered_;
  for (int k = 0; k < 8; ++k)
    tail[pad + k] = static_cast<unsigned char>(bit_length >> (56 - 8 * k));
  Update(std::string_view(reinterpret_cast<const char*>(tail), pad + 8));
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (std::uint32_t word : state_) {
    for (int s = 28; s >= 0; s -= 4) out += hex[(word >> s) & 0xf];
  }
  return out;
}

std::string Sha256Hex(const std::string& bytes) {
  Sha256 sha;
  sha.Update(bytes);
  return sha.HexDigest();
}

}  // namespace blmd
