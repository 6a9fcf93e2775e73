#include "sim/metrics/relative_error_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "sim/util/hash.h"
#include "sim/util/input_error.h"

namespace restir {

namespace {

constexpr char kMagic[8] = {'R', 'S', 'R', 'E', 'L', 'E', '0', '1'};

size_t Values(int width, int height) { return size_t(3) * size_t(width) * size_t(height); }

}  // namespace

uint64_t RelativeErrorFileSize(int width, int height, int frames) {
  return kRelativeErrorHeaderSize + uint64_t(frames) * (Values(width, height) * sizeof(float) + sizeof(uint64_t));
}

std::string EncodeRelativeErrorHeader(int width, int height, int frames) {
  std::string out(kMagic, sizeof(kMagic));
  for (int32_t v : {int32_t(width), int32_t(height), int32_t(frames)})
    out.append(reinterpret_cast<const char*>(&v), sizeof(v));
  return out;
}

std::string EncodeRelativeErrorFrame(const std::vector<float>& values) {
  std::string out(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  const uint64_t sum = Fnv1a(out.data(), out.size());
  out.append(reinterpret_cast<const char*>(&sum), sizeof(sum));
  return out;
}

bool DecodeRelativeErrorHeader(const std::string& bytes, int width, int height, int frames, std::string& problem) {
  if (bytes.size() != kRelativeErrorHeaderSize || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    problem = "not a relative-error file of this version";
    return false;
  }
  int32_t v[3];
  std::memcpy(v, bytes.data() + sizeof(kMagic), sizeof(v));
  if (v[0] != width || v[1] != height || v[2] != frames) {
    problem = "written for " + std::to_string(v[0]) + "x" + std::to_string(v[1]) + " and " + std::to_string(v[2]) +
              " frames, not " + std::to_string(width) + "x" + std::to_string(height) + " and " +
              std::to_string(frames);
    return false;
  }
  return true;
}

bool DecodeRelativeErrorFrame(const std::string& bytes, size_t count, std::vector<float>& values,
                              std::string& problem) {
  if (bytes.size() != count * sizeof(float) + sizeof(uint64_t)) {
    problem = "wrong size";
    return false;
  }
  uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + count * sizeof(float), sizeof(stored));
  if (Fnv1a(bytes.data(), count * sizeof(float)) != stored) {
    problem = "checksum mismatch: damaged or truncated";
    return false;
  }
  values.resize(count);
  std::memcpy(values.data(), bytes.data(), count * sizeof(float));
  for (float v : values)
    if (!std::isfinite(v)) {
      problem = "a non-finite value";
      return false;
    }
  return true;
}

RelativeErrorFile::RelativeErrorFile(const std::string& path, int width, int height, int frames)
    : path_(path), count_(Values(width, height)) {
  auto fail = [&](const std::string& why) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    throw InputError(path + ": error: unusable relative-error file (" + why + ")");
  };
  // O_NONBLOCK: a FIFO put in its place is refused below, not waited on.
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd_ < 0) fail(std::strerror(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) fail("not a regular file");
  if (uint64_t(st.st_size) != RelativeErrorFileSize(width, height, frames)) fail("wrong size");
  std::string header(kRelativeErrorHeaderSize, '\0'), problem;
  if (::pread(fd_, header.data(), header.size(), 0) != ssize_t(header.size())) fail("cannot read its header");
  if (!DecodeRelativeErrorHeader(header, width, height, frames, problem)) fail(problem);
}

RelativeErrorFile::~RelativeErrorFile() {
  if (fd_ >= 0) ::close(fd_);
}

void RelativeErrorFile::ReadFrame(int k, std::vector<float>& values) const {
  const size_t block = count_ * sizeof(float) + sizeof(uint64_t);
  std::string bytes(block, '\0');
  size_t done = 0;
  const off_t at = off_t(kRelativeErrorHeaderSize) + off_t(k) * off_t(block);
  while (done < block) {
    const ssize_t n = ::pread(fd_, bytes.data() + done, block - done, at + off_t(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw InputError(path_ + ": error: unusable relative-error file (cannot read frame " +
                                 std::to_string(k) + ")");
    done += size_t(n);
  }
  std::string problem;
  if (!DecodeRelativeErrorFrame(bytes, count_, values, problem))
    throw InputError(path_ + ": error: unusable relative-error file (frame " + std::to_string(k) + ": " + problem +
                     ")");
}

}  // namespace restir
