// A file opened for reading (private to io/): the descriptor, closed on destruction, and its
// size, with the errors every reader of a path gives the same way: "PATH: cannot read: why"
// (a missing file, no permission, a directory).
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstring>
#include <string>

#include "blmd/error.h"

namespace blmd::internal {

class ReadableFile {
 public:
  explicit ReadableFile(const std::string& path) : path_(path) {
    fd_ = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) Fail(errno);
    struct stat info {};
    if (fstat(fd_, &info) != 0) Fail(errno);
    if (S_ISDIR(info.st_mode)) Fail(EISDIR);
    regular_ = S_ISREG(info.st_mode);
    size_ = regular_ ? static_cast<std::size_t>(info.st_size) : 0;
  }
  ~ReadableFile() {
    if (fd_ >= 0) close(fd_);
  }
  ReadableFile(const ReadableFile&) = delete;
  ReadableFile& operator=(const ReadableFile&) = delete;

  // The size of a regular file, 0 for a pipe or a device (read until the end).
  std::size_t size() const { return size_; }
  bool regular() const { return regular_; }
  // Up to `bytes` into `into` (interrupted reads retried); 0 at the end.
  std::size_t ReadSome(char* into, std::size_t bytes) const {
    while (true) {
      const ssize_t n = read(fd_, into, bytes);
      if (n >= 0) return static_cast<std::size_t>(n);
      if (errno != EINTR) Fail(errno);
    }
  }

 private:
  [[noreturn]] void Fail(int error) const {
    throw InputError(path_ + ": cannot read: " + std::strerror(error));
  }

  std::string path_;
  int fd_ = -1;
  bool regular_ = false;
  std::size_t size_ = 0;
};

}  // namespace blmd::internal
