// Seed ensembles across jobs (DESIGN §6, docs/sweep-format.md): the runs of one configuration that differ only in
// their seed, split into relative bias² and variance with confidence intervals. The split needs each seed's
// per-pixel error, not just its relmse: sweep jobs with siblings keep their relative-error frames
// (sim/metrics/relative_error_file.h), and the merge feeds them here frame by frame (memory: one frame of every seed).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sim/util/image.h"

namespace restir {

// relmse's per-value error, signed: (I − R) / sqrt(R² + 0.01), so that relmse is the mean of its squares
// (docs/metrics.md). Appends the frame's 3·w·h values, pixel by pixel, R G B.
void AppendRelativeError(const ImageRgb& estimate, const ImageRgb& reference, std::vector<float>& out);

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
