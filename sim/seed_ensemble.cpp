#include "sim/seed_ensemble.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "sim/compare.h"
#include "sim/hash.h"
#include "sim/metrics.h"
#include "sim/sequence.h"  // InputError

namespace restir {

namespace {

constexpr char kMagic[8] = {'R', 'S', 'R', 'E', 'L', 'E', '0', '1'};

size_t Values(int width, int height) { return size_t(3) * size_t(width) * size_t(height); }

}  // namespace

void AppendRelativeError(const ImageRgb& estimate, const ImageRgb& reference, std::vector<float>& out) {
  out.reserve(out.size() + 3 * estimate.Size());
  for (size_t i = 0; i < estimate.Size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double r = reference.pixels[i][c];
      const double d = double(estimate.pixels[i][c]) - r;
      out.push_back(static_cast<float>(d / std::sqrt(RelmseDenominator(r))));
    }
}

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

SeedSplit::SeedSplit(int seeds) : seeds_(seeds), bias2Without_(size_t(seeds), 0.0), varianceWithout_(size_t(seeds), 0.0) {}

void SeedSplit::AddFrame(const std::vector<const float*>& errors, size_t count, double referenceNoise) {
  const int s = seeds_;
  if (s < 2 || count == 0 || errors.size() != size_t(s)) return;
  // Per value: the seeds' sum and sum of squares, so each delete-one statistic costs O(1) per seed.
  double meanSq = 0.0, var = 0.0;
  std::vector<double> meanSqWithout(size_t(s), 0.0), varWithout(size_t(s), 0.0);
  for (size_t i = 0; i < count; ++i) {
    double t1 = 0.0;
    for (int k = 0; k < s; ++k) t1 += errors[size_t(k)][i];
    const double mean = t1 / s;
    double ss = 0.0;  // Σ (e − ē)², two-pass for accuracy
    for (int k = 0; k < s; ++k) {
      const double d = errors[size_t(k)][i] - mean;
      ss += d * d;
    }
    meanSq += mean * mean;
    var += ss / (s - 1);
    if (s >= 3) {
      for (int k = 0; k < s; ++k) {
        // Without seed k: mean m' = ē − (e_k − ē)/(S − 1); Σ over the others of (e − m')² = ss − S/(S − 1) (e_k − ē)².
        const double d = errors[size_t(k)][i] - mean;
        const double m = mean - d / (s - 1);
        const double ssWithout = std::max(0.0, ss - double(s) / (s - 1) * d * d);
        meanSqWithout[size_t(k)] += m * m;
        varWithout[size_t(k)] += ssWithout / (s - 2);
      }
    }
  }
  const double n = double(count);
  const double v = var / n;
  varianceSum_ += v;
  bias2Sum_ += meanSq / n - v / s - referenceNoise;
  if (s >= 3)
    for (int k = 0; k < s; ++k) {
      const double vk = varWithout[size_t(k)] / n;
      varianceWithout_[size_t(k)] += vk;
      bias2Without_[size_t(k)] += meanSqWithout[size_t(k)] / n - vk / (s - 1) - referenceNoise;
    }
  ++frames_;
}

SeedSplitResult SeedSplit::Result() const {
  SeedSplitResult r;
  r.seeds = seeds_;
  if (seeds_ < 2 || frames_ == 0) return r;
  const double f = frames_;
  r.bias2 = bias2Sum_ / f;
  r.variance = varianceSum_ / f;
  if (seeds_ >= 3) {
    // Jackknife standard error: sqrt((S − 1)/S Σ (θ_(k) − θ̄_(·))²).
    auto halfWidth = [&](const std::vector<double>& without) {
      double mean = 0.0;
      for (double x : without) mean += x / f;
      mean /= seeds_;
      double ss = 0.0;
      for (double x : without) ss += (x / f - mean) * (x / f - mean);
      return StudentT975(seeds_ - 1) * std::sqrt(double(seeds_ - 1) / seeds_ * ss);
    };
    r.bias2Ci95 = halfWidth(bias2Without_);
    r.varianceCi95 = halfWidth(varianceWithout_);
  }
  return r;
}

double StudentT975(int dof) {
  if (dof < 1) return NAN;
  // Bisection on the two-sided p-value: P(|T| >= t) = 0.05.
  double lo = 0.0, hi = 1000.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (StudentTTwoSidedP(mid, dof) > 0.05 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace restir
