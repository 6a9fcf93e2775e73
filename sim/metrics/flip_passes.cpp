// FLIP's filter kernels and its two filter passes over rows (sim/metrics/flip_internal.h), and the buffers they use.
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <new>

#include "sim/metrics/flip_internal.h"

namespace restir::flip_detail {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Contrast sensitivity functions as sums of two Gaussians in the frequency domain (FLIP 2020, §4.1, Table 1):
// S(f) = a1 exp(-b1 f²) + a2 exp(-b2 f²), per opponent channel; b2 = 1e-5 only avoids a division by 0 where
// a2 = 0.
struct CsfParams {
  double a1, b1, a2, b2;
};
constexpr CsfParams kCsfAchromatic{1.0, 0.0047, 0.0, 1e-5};
constexpr CsfParams kCsfRedGreen{1.0, 0.0053, 0.0, 1e-5};
constexpr CsfParams kCsfBlueYellow{34.1, 0.04, 13.5, 0.025};

}  // namespace

FlipKernels::FlipKernels(double ppd) {
  // CSF filters: the spatial-domain version of each sum of Gaussians, a sqrt(pi / b) exp(-pi² r² / b) with r
  // in degrees, sampled every 1 / ppd degrees over a radius of 3 standard deviations of the widest Gaussian and
  // normalised to unit sum over the 2D footprint. Each term is separable, so the 2D kernel is a weighted sum of
  // products of normalised 1D Gaussians.
  const double bMax = std::max({kCsfAchromatic.b1, kCsfAchromatic.b2, kCsfRedGreen.b1, kCsfRedGreen.b2,
                                kCsfBlueYellow.b1, kCsfBlueYellow.b2});
  csfRadius = static_cast<int>(std::ceil(3.0 * std::sqrt(bMax / (2.0 * kPi * kPi)) * ppd));
  auto gaussian = [&](double b, double& sum) {
    Kernel k;
    k.radius = csfRadius;
    std::vector<double> e(2 * csfRadius + 1);
    sum = 0.0;
    for (int i = -csfRadius; i <= csfRadius; ++i) {
      const double x = i / ppd;
      e[i + csfRadius] = std::exp(-kPi * kPi * x * x / b);
      sum += e[i + csfRadius];
    }
    for (double v : e) k.w.push_back(static_cast<float>(v / sum));
    return k;
  };
  double s1 = 0.0, s2 = 0.0;
  achromatic = gaussian(kCsfAchromatic.b1, s1);  // a2 = 0 for the achromatic and red-green channels
  redGreen = gaussian(kCsfRedGreen.b1, s1);
  blueYellow1 = gaussian(kCsfBlueYellow.b1, s1);
  blueYellow2 = gaussian(kCsfBlueYellow.b2, s2);
  const double m1 = kCsfBlueYellow.a1 * std::sqrt(kPi / kCsfBlueYellow.b1) * s1 * s1;
  const double m2 = kCsfBlueYellow.a2 * std::sqrt(kPi / kCsfBlueYellow.b2) * s2 * s2;
  blueYellowWeight1 = static_cast<float>(m1 / (m1 + m2));
  blueYellowWeight2 = static_cast<float>(m2 / (m1 + m2));

  // Feature detectors: standard deviation half the peak-to-trough width (0.082 degrees) in pixels, radius
  // 3 sd. The 2D kernels are f(x) g(y) with g a Gaussian; normalising positive weights to sum 1 and negative
  // weights to sum -1 over the 2D footprint equals normalising f that way and g to unit sum.
  const double sd = 0.5 * kFeatureWidthDegrees * ppd;
  featureRadius = static_cast<int>(std::ceil(3.0 * sd));
  const int r = featureRadius;
  std::vector<double> g(2 * r + 1), fe(2 * r + 1), fp(2 * r + 1);
  double gSum = 0.0;
  for (int i = -r; i <= r; ++i) {
    const double gi = std::exp(-double(i) * i / (2.0 * sd * sd));
    g[i + r] = gi;
    gSum += gi;
    fe[i + r] = -double(i) * gi;
    fp[i + r] = (double(i) * i / (sd * sd) - 1.0) * gi;
  }
  auto normalisedSigned = [r](const std::vector<double>& f) {
    double pos = 0.0, neg = 0.0;
    for (double v : f) {
      if (v > 0.0) pos += v;
      if (v < 0.0) neg -= v;
    }
    Kernel k;
    k.radius = r;
    for (double v : f) k.w.push_back(static_cast<float>(v > 0.0 ? v / pos : (v < 0.0 ? v / neg : 0.0)));
    return k;
  };
  gauss.radius = r;
  for (double v : g) gauss.w.push_back(static_cast<float>(v / gSum));
  edge = normalisedSigned(fe);
  point = normalisedSigned(fp);
  pad = std::max(csfRadius, featureRadius);
}


// HyAB(Hunt(Lab(green)), Hunt(Lab(blue)))^q_c with cbrt and pow correctly rounded, which is what GCC folds the
// expression to at compile time and what this program has always used; calling glibc 2.36's cbrtf at run time
// gives one ulp less (0x1.4a357p+5). A constant, so that neither inlining decisions nor the C library move it
// (tests/sim/metrics/flip_legacy_test.cpp recomputes it).
float MaxHyabPow() { return 0x1.4a3572p+5f; }

namespace {
constexpr size_t kHugeBytes = size_t(4) << 20, kHugePage = size_t(2) << 20;
size_t HugeRounded(size_t bytes) { return (bytes + kHugePage - 1) / kHugePage * kHugePage; }
}  // namespace

void* AllocateRows(size_t bytes) {
  if (bytes < kHugeBytes) return ::operator new(bytes, std::align_val_t{64});
  void* p = ::operator new(HugeRounded(bytes), std::align_val_t{kHugePage});
#ifdef MADV_HUGEPAGE
  madvise(p, HugeRounded(bytes), MADV_HUGEPAGE);  // advice only: without transparent huge pages nothing changes
#endif
  return p;
}

void FreeRows(void* p, size_t bytes) {
  if (bytes < kHugeBytes)
    ::operator delete(p, std::align_val_t{64});
  else
    ::operator delete(p, std::align_val_t{kHugePage});
}

Scratch::Scratch(int width, int padIn)
    : stride(RowStride(width)),
      pad(padIn),
      ringRows(2 * padIn + 1),
      padded(4 * size_t(stride + 2 * padIn)),
      ring(size_t(kHorizontalPlanes) * ringRows * stride),
      filtered(size_t(kFilteredPlanes) * stride),
      features(size_t(kFeaturePlanes) * stride),
      compare(4 * size_t(stride)),
      taps(size_t(ringRows)) {}

void HorizontalRow(const ImageRgb& image, const FlipKernels& k, double scale, int y, Scratch& s) {
  const int w = image.width, pad = s.pad;
  float* rows[4] = {s.Padded(0), s.Padded(1), s.Padded(2), s.Padded(3)};  // yy, cx, cz, lum
  static_assert(sizeof(Vec3) == 3 * sizeof(float), "rows are read as interleaved floats");
  const float* rgb = &image.pixels[size_t(y) * w].x;
  PrepareRow(rgb, w, scale, rows[0] + pad, rows[1] + pad, rows[2] + pad, rows[3] + pad);
  for (float* b : rows) {
    std::fill(b, b + pad, b[pad]);
    std::fill(b + pad + w, b + 2 * pad + s.stride, b[pad + w - 1]);
  }
  // Kernels over the same row share one sweep (CorrelateRows); the Cz and the feature kernels share radii.
  auto correlate = [&](const float* padded, std::initializer_list<const Kernel*> plain,
                       std::initializer_list<const Kernel*> centred, std::initializer_list<int> planes) {
    const int r = (plain.size() ? *plain.begin() : *centred.begin())->radius;
    const float* w[3];
    float* out[3];
    int k = 0;
    for (const Kernel* kernel : plain) w[k++] = kernel->w.data();
    for (const Kernel* kernel : centred) w[k++] = kernel->w.data();
    k = 0;
    for (int plane : planes) out[k++] = s.Ring(plane, y);
    for (int t = 0; t < 2 * r + 1; ++t) s.taps[t] = padded + (pad - r) + t;
    CorrelateRows(s.taps.data(), w, int(plain.size()), int(centred.size()), 2 * r + 1, padded + pad, r, s.stride,
                  out);
  };
  correlate(rows[0], {&k.achromatic}, {}, {kHorY});
  correlate(rows[1], {&k.redGreen}, {}, {kHorCx});
  correlate(rows[2], {&k.blueYellow1, &k.blueYellow2}, {}, {kHorCz1, kHorCz2});
  correlate(rows[3], {&k.gauss}, {&k.edge, &k.point}, {kHorGauss, kHorEdge, kHorPoint});
}

void VerticalRow(const FlipKernels& k, int height, int y, Scratch& s) {
  auto taps = [&](int plane, int r) {
    for (int t = 0; t < 2 * r + 1; ++t) s.taps[t] = s.Ring(plane, std::clamp(y - r + t, 0, height - 1));
    return s.taps.data();
  };
  auto correlate = [&](int plane, const Kernel& kernel, int out) {
    CorrelateRow(taps(plane, kernel.radius), kernel.w.data(), 2 * kernel.radius + 1, nullptr, 0, s.stride,
                 s.Filtered(out));
  };
  correlate(kHorY, k.achromatic, kFiltY);
  correlate(kHorCx, k.redGreen, kFiltCx);
  correlate(kHorCz1, k.blueYellow1, kFiltCz1);
  correlate(kHorCz2, k.blueYellow2, kFiltCz2);
  correlate(kHorEdge, k.gauss, kFiltEx);   // d/dx, smoothed in y
  correlate(kHorPoint, k.gauss, kFiltPx);  // d²/dx²
  // d/dy and d²/dy², smoothed in x: both centred on the Gaussian plane's row y, in one sweep.
  const float* w[2] = {k.edge.w.data(), k.point.w.data()};
  float* out[2] = {s.Filtered(kFiltEy), s.Filtered(kFiltPy)};
  CorrelateRows(taps(kHorGauss, k.edge.radius), w, 0, 2, 2 * k.edge.radius + 1, s.Ring(kHorGauss, y), k.edge.radius,
                s.stride, out);
  const float* filtered[kFilteredPlanes];
  float* features[kFeaturePlanes];
  for (int p = 0; p < kFilteredPlanes; ++p) filtered[p] = s.Filtered(p);
  for (int p = 0; p < kFeaturePlanes; ++p) features[p] = s.Feature(p);
  FeatureRow(filtered, k.blueYellowWeight1, k.blueYellowWeight2, s.stride, features);
}

}  // namespace restir::flip_detail
