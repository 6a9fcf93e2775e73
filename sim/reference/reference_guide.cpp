#include "sim/reference/reference_guide.h"

#include <algorithm>
#include <cmath>

namespace restir {

namespace {

constexpr float kTwoPi = 6.28318530717958647692f;
constexpr float kBinSolidAngle = 2.0f * kTwoPi / float(kGuideBins);  // 4π / bins

}  // namespace

int GuideBin(const Vec3& dir) {
  const float z = std::clamp(dir.y, -1.0f, 1.0f);
  float phi = std::atan2(dir.z, dir.x);
  if (phi < 0.0f) phi += kTwoPi;
  const int row = std::clamp(static_cast<int>((z + 1.0f) * 0.5f * kGuideRows), 0, kGuideRows - 1);
  const int column = std::clamp(static_cast<int>(phi / kTwoPi * kGuideColumns), 0, kGuideColumns - 1);
  return row * kGuideColumns + column;
}

DirectionGuide::DirectionGuide(const double* weights) {
  double sum = 0.0;
  for (int b = 0; b < kGuideBins; ++b) {
    const double w = weights[b];
    if (std::isfinite(w) && w > 0.0) sum += w;
    cdf_[static_cast<size_t>(b)] = static_cast<float>(sum);
  }
  total_ = cdf_.back();
}

float DirectionGuide::Pdf(const Vec3& dir) const {
  if (Empty()) return 0.0f;
  const int b = GuideBin(dir);
  const float below = b > 0 ? cdf_[static_cast<size_t>(b - 1)] : 0.0f;
  return (cdf_[static_cast<size_t>(b)] - below) / total_ / kBinSolidAngle;
}

Vec3 DirectionGuide::Sample(float u0, float u1) const {
  const float target = u0 * total_;
  // The first bin whose cumulative weight exceeds the target: a bin of weight 0 is never chosen.
  const size_t b = std::min<size_t>(
      static_cast<size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), target) - cdf_.begin()), kGuideBins - 1);
  const float below = b > 0 ? cdf_[b - 1] : 0.0f;
  const float width = cdf_[b] - below;
  const float v = width > 0.0f ? std::clamp((target - below) / width, 0.0f, 0.99999994f) : 0.5f;
  const int row = static_cast<int>(b) / kGuideColumns, column = static_cast<int>(b) % kGuideColumns;
  const float z = std::clamp(-1.0f + 2.0f * (float(row) + v) / float(kGuideRows), -1.0f, 1.0f);
  const float phi = kTwoPi * (float(column) + u1) / float(kGuideColumns);
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return Vec3(r * std::cos(phi), z, r * std::sin(phi));
}

}  // namespace restir
