#include "sim/metrics/seed_ensemble.h"

#include <algorithm>

#include "sim/metrics/compare.h"
#include "sim/metrics/metrics.h"  // RelmseDenominator

namespace restir {

void AppendRelativeError(const ImageRgb& estimate, const ImageRgb& reference, std::vector<float>& out) {
  out.reserve(out.size() + 3 * estimate.Size());
  for (size_t i = 0; i < estimate.Size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double r = reference.pixels[i][c];
      const double d = double(estimate.pixels[i][c]) - r;
      out.push_back(static_cast<float>(d / std::sqrt(RelmseDenominator(r))));
    }
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
