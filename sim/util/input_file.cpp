#include "sim/util/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <cstdio>
#include <cstring>

#include "sim/util/input_error.h"

namespace restir {

namespace {

// An open descriptor of a regular file of at most maxBytes (its size in `size`), or -1 with `problem` set.
int OpenRegularFile(const std::string& path, size_t maxBytes, size_t& size, std::string& problem) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below as not a regular file.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    problem = errno == ENOENT ? "no such file" : std::strerror(errno);
    return -1;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    problem = S_ISDIR(st.st_mode) ? "a directory, not a file" : "not a regular file";
    ::close(fd);
    return -1;
  }
  if (static_cast<unsigned long long>(st.st_size) > maxBytes) {
    problem = "larger than " + FormatBytes(double(maxBytes));
    ::close(fd);
    return -1;
  }
  size = static_cast<size_t>(st.st_size);
  return fd;
}

}  // namespace

bool IsReadableRegularFile(const std::string& path, size_t maxBytes, std::string& problem) {
  size_t size = 0;
  const int fd = OpenRegularFile(path, maxBytes, size, problem);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

bool TryReadRegularFile(const std::string& path, size_t maxBytes, std::string& bytes, std::string& problem) {
  size_t size = 0;
  const int fd = OpenRegularFile(path, maxBytes, size, problem);
  if (fd < 0) return false;
  bytes.resize(size);
  size_t done = 0;
  for (;;) {
    if (done == bytes.size()) {
      // The file may have grown since fstat: read on, within the limit.
      if (bytes.size() >= maxBytes) {
        char probe;
        const ssize_t n = ::read(fd, &probe, 1);
        if (n > 0) {
          problem = "larger than " + FormatBytes(double(maxBytes));
          ::close(fd);
          return false;
        }
        break;
      }
      bytes.resize(std::min(maxBytes, bytes.size() * 2 + 4096));
    }
    const ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      problem = std::strerror(errno);
      ::close(fd);
      return false;
    }
    if (n == 0) break;
    done += static_cast<size_t>(n);
  }
  ::close(fd);
  bytes.resize(done);
  return true;
}

std::string ReadInputFile(const std::string& path, size_t maxBytes, const std::string& what) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, maxBytes, bytes, problem))
    throw InputError(path + ": error: cannot read " + what + " (" + problem + ")");
  return bytes;
}

std::string FormatBytes(double bytes) {
  char buf[64];
  if (bytes >= 1024.0 * 1024.0 * 1024.0) std::snprintf(buf, sizeof(buf), "%.3g GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  else if (bytes >= 1024.0 * 1024.0) std::snprintf(buf, sizeof(buf), "%.3g MiB", bytes / (1024.0 * 1024.0));
  else if (bytes >= 1024.0) std::snprintf(buf, sizeof(buf), "%.3g KiB", bytes / 1024.0);
  else std::snprintf(buf, sizeof(buf), "%.0f bytes", bytes);
  return buf;
}

}  // namespace restir
