// Seed ensembles across jobs (DESIGN §6, docs/sweep-format.md): the runs of one configuration that differ only in
// their seed, split into relative bias² and variance with confidence intervals. The split needs each seed's
// per-pixel error, not just its relmse, so a sweep job with siblings keeps its relative-error frames in a file;
// the merge reads the seeds' files frame by frame (memory: one frame of every seed).
//
// The runs may come from different machines, so the file is input like any other (DESIGN §10): sized, checked
// per frame by a checksum, every value finite. Encoding and decoding are pure functions of bytes.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/image.h"

namespace restir {

// relmse's per-value error, signed: (I − R) / sqrt(R² + 0.01), so that relmse is the mean of its squares
// (docs/metrics.md). Appends the frame's 3·w·h values, pixel by pixel, R G B.
void AppendRelativeError(const ImageRgb& estimate, const ImageRgb& reference, std::vector<float>& out);

// Layout, little-endian: "RSRELE01" | width i32 | height i32 | frames i32 | then per frame: 3·w·h floats and the
// FNV-1a 64 of their bytes.
constexpr size_t kRelativeErrorHeaderSize = 8 + 3 * 4;
std::string EncodeRelativeErrorHeader(int width, int height, int frames);
// One frame's block: its values and their checksum.
std::string EncodeRelativeErrorFrame(const std::vector<float>& values);
// False with `problem` unless `bytes` is a header for width × height × frames.
bool DecodeRelativeErrorHeader(const std::string& bytes, int width, int height, int frames, std::string& problem);
// False with `problem` unless `bytes` is one frame's block of `count` finite values; fills `values`.
bool DecodeRelativeErrorFrame(const std::string& bytes, size_t count, std::vector<float>& values, std::string& problem);
// The whole file's size for width × height × frames.
uint64_t RelativeErrorFileSize(int width, int height, int frames);

// Reads one job's file frame by frame. Throws InputError naming the file when it is not such a file.
class RelativeErrorFile {
 public:
  RelativeErrorFile(const std::string& path, int width, int height, int frames);
  ~RelativeErrorFile();
  RelativeErrorFile(const RelativeErrorFile&) = delete;
  RelativeErrorFile& operator=(const RelativeErrorFile&) = delete;
  // Frame k (0-based within the file). Throws InputError on a damaged block.
  void ReadFrame(int k, std::vector<float>& values) const;

 private:
  std::string path_;
  int fd_ = -1;
  size_t count_ = 0;  // values per frame
};

// The split of S >= 2 seeds, each a mean over frames of per-frame means over pixels and channels, in relmse's
// units. With e_s the relative error of seed s, ē their mean and v = Σ (e_s − ē)² / (S − 1):
//   variance = mean v                          (one seed's variance; unbiased)
//   bias2    = mean ē² − variance / S − n_R    (unbiased for the bias² of the estimator against the true image,
//                                               n_R the reference's own noise, relmse − relmse_corrected)
// so that mean over seeds of relmse = bias2 + variance + n_R in expectation. Intervals: the jackknife over seeds
// (delete one seed), half-width t(0.975, S − 1) · its standard error; they need S >= 3.
struct SeedSplitResult {
  int seeds = 0;
  double bias2 = NAN, bias2Ci95 = NAN;
  double variance = NAN, varianceCi95 = NAN;
};

class SeedSplit {
 public:
  explicit SeedSplit(int seeds);
  // One frame: errors[s] points at seed s's `count` relative errors; referenceNoise is the frame's n_R.
  void AddFrame(const std::vector<const float*>& errors, size_t count, double referenceNoise);
  SeedSplitResult Result() const;

 private:
  int seeds_;
  int frames_ = 0;
  double bias2Sum_ = 0.0, varianceSum_ = 0.0;     // Σ over frames of the frame's estimates
  std::vector<double> bias2Without_, varianceWithout_;  // the same without seed s (jackknife)
};

// Half-width factor of a two-sided 95% Student t interval: t(0.975, dof).
double StudentT975(int dof);

}  // namespace restir
