// FLIP's internals, shared by sim/metrics/flip.cpp (the drivers), sim/metrics/flip_passes.cpp (kernels, the two
// filter passes) and sim/metrics/flip_rows.cpp (the per-row SIMD stages). Not part of the public interface
// (sim/metrics/flip.h).
//
// Bit-exactness: every stage computes each pixel with the float/double operations of the pre-optimisation code, in
// its order (no contraction: the project compiles with -ffp-contract=off), so any SIMD target, thread count and
// split of the image into rows, blocks and lanes gives the same bits. Where a C library call was replaced, the
// replacement was checked to return the same bits over every input FLIP can give it: the cube root (CbrtRow),
// pow(d, 0.5) (FeatureTerm) and the powers PowOrShortcut skips. tests/sim/metrics/flip_legacy_test.cpp keeps the
// pre-optimisation implementation as the oracle and samples each of those checks.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <new>
#include <utility>
#include <vector>

#include "core/math.h"
#include "sim/util/image.h"

namespace restir::flip_detail {

// --- Constants of the papers -------------------------------------------------------------------------------

// Colour pipeline (FLIP 2020, §4.1): exponent of the HyAB distance and the error redistribution.
constexpr float kQc = 0.7f;
constexpr float kPc = 0.4f;
constexpr float kPt = 0.95f;
// Feature pipeline (§4.2): exponent, and the peak-to-trough width of the edge detector in degrees.
constexpr double kQf = 0.5;
constexpr double kFeatureWidthDegrees = 0.082;

// HDR-FLIP's ACES tone mapper (Narkowicz's fit, with the fit's 0.6 pre-exposure folded in):
// t(x) = (k0 x² + k1 x + k2) / (k3 x² + k4 x + k5).
constexpr double kTm0 = 0.6 * 0.6 * 2.51, kTm1 = 0.6 * 0.03, kTm2 = 0.0;
constexpr double kTm3 = 0.6 * 0.6 * 2.43, kTm4 = 0.6 * 0.59, kTm5 = 0.14;
// Inputs beyond this tone-map to the curve's limit k0/k3 > 1, clamped to 1 (and x² would overflow near 1e154).
constexpr double kToneMapHuge = 1e100;

// Linear sRGB <-> CIE XYZ (D65), and the D65 reference white.
constexpr float kRgbToXyz[3][3] = {{10135552.0f / 24577794.0f, 8788810.0f / 24577794.0f, 4435075.0f / 24577794.0f},
                                   {2613072.0f / 12288897.0f, 8788810.0f / 12288897.0f, 887015.0f / 12288897.0f},
                                   {1425312.0f / 73733382.0f, 8788810.0f / 73733382.0f, 70074185.0f / 73733382.0f}};
constexpr float kXyzToRgb[3][3] = {{3.241003275f, -1.537398934f, -0.498615861f},
                                   {-0.969224334f, 1.875930071f, 0.041554224f},
                                   {0.055639423f, -0.204011202f, 1.057148933f}};
constexpr float kWhite[3] = {0.950428545f, 1.0f, 1.088900371f};
constexpr float kInvWhite[3] = {1.052156925f, 1.0f, 0.918357670f};

// CIE L*a*b*'s f(t): the cube root above (6/29)³, the linear segment below.
constexpr float kLabDelta = 6.0f / 29.0f;
constexpr float kLabDeltaCube = kLabDelta * kLabDelta * kLabDelta;
constexpr float kLabFactor = 1.0f / (3.0f * kLabDelta * kLabDelta);
constexpr float kLabOffset = 4.0f / 29.0f;

// --- Scalar formulas (the reference every SIMD stage reproduces lane by lane) ----------------------------------

struct Color3 {
  float v[3];
};

inline Color3 MulMatrix(const float m[3][3], float a, float b, float c) {
  return {{m[0][0] * a + m[0][1] * b + m[0][2] * c, m[1][0] * a + m[1][1] * b + m[1][2] * c,
           m[2][0] * a + m[2][1] * b + m[2][2] * c}};
}

// Linear RGB -> YCxCz (the opponent space of the colour pipeline).
inline Color3 LinearRgbToYcxcz(float r, float g, float b) {
  const Color3 xyz = MulMatrix(kRgbToXyz, r, g, b);
  const float x = xyz.v[0] * kInvWhite[0], y = xyz.v[1] * kInvWhite[1], z = xyz.v[2] * kInvWhite[2];
  return {{116.0f * y - 16.0f, 500.0f * (x - y), 200.0f * (y - z)}};
}

// Linear RGB -> CIE L*a*b* (D65).
inline Color3 LinearRgbToLab(float r, float g, float b) {
  const Color3 xyz = MulMatrix(kRgbToXyz, r, g, b);
  float f[3];
  for (int c = 0; c < 3; ++c) {
    const float t = xyz.v[c] * kInvWhite[c];
    f[c] = t > kLabDeltaCube ? std::cbrt(t) : kLabFactor * t + kLabOffset;
  }
  return {{116.0f * f[1] - 16.0f, 500.0f * (f[0] - f[1]), 200.0f * (f[1] - f[2])}};
}

// Hunt adjustment: chroma scales with lightness, a* and b* multiplied by 0.01 L*.
inline Color3 Hunt(const Color3& lab) {
  const float s = 0.01f * lab.v[0];
  return {{lab.v[0], s * lab.v[1], s * lab.v[2]}};
}

// HyAB: city-block in lightness, Euclidean in the chromatic plane. Symmetric bit for bit.
inline float HyAB(const Color3& p, const Color3& q) {
  const float dl = p.v[0] - q.v[0], da = p.v[1] - q.v[1], db = p.v[2] - q.v[2];
  return std::fabs(dl) + std::sqrt(da * da + db * db);
}

// Maps the exponentiated HyAB distance to [0, 1]: [0, p_c cmax) linearly onto [0, p_t), the rest onto [p_t, 1].
inline float Redistribute(float powHyab, float cmax) {
  const float pcCmax = kPc * cmax;
  const float e = powHyab < pcCmax ? (kPt / pcCmax) * powHyab
                                   : kPt + ((powHyab - pcCmax) / (cmax - pcCmax)) * (1.0f - kPt);
  return std::min(e, 1.0f);  // the paper's cmax is the gamut's largest distance; guard rounding only
}

inline float Clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }  // NaN -> 0

inline double ToneMapX(double x) {
  if (!(x > 0.0)) return 0.0;           // negative and NaN
  if (x > kToneMapHuge) return 1.0;     // +inf and beyond the double range of x²
  const double y = (kTm0 * x * x + kTm1 * x + kTm2) / (kTm3 * x * x + kTm4 * x + kTm5);
  return std::min(y, 1.0);
}

// The feature pipeline's last step, min(1, float((featureDiff / sqrt 2)^q_f)), is a square root for q_f = 1/2:
// std::pow(d, 0.5) and std::sqrt(d) were checked to round to the same float for d = double(f) / sqrt(2) and every
// non-negative float f (all 2^31 of them, glibc 2.36, both its FMA and its SSE2 pow;
// tests/sim/metrics/flip_legacy_test.cpp
// samples the check).
static_assert(kQf == 0.5, "FeatureTerm's sqrt stands for pow(d, q_f) only with q_f = 0.5");
inline float FeatureTerm(float featureDiff) {
  return std::min(1.0f, static_cast<float>(std::sqrt(double(featureDiff) / std::sqrt(2.0))));
}

// std::pow(base, exponent) for base and exponent in [0, 1], without the call where the result is known: 0^e = 0
// for e > 0 and b^0 = 1 (C's Annex F), and b^1 = b, which glibc 2.36's powf (its FMA and its SSE2 build) was
// checked to return for every float b in [0, 1]. Black or saturated regions (equal in both images) take these.
// Otherwise the call stays scalar: glibc's powf has no SIMD twin that rounds like it.
inline float PowOrShortcut(float base, float exponent) {
  if (base == 0.0f) return exponent > 0.0f ? 0.0f : 1.0f;
  if (exponent == 1.0f) return base;
  return std::pow(base, exponent);
}

// One pixel's FLIP value from its HyAB distance and feature difference: ΔE_c^(1 - ΔE_f), clamped.
inline float FlipFromDifferences(float hyab, float featureDiff, float cmax) {
  return Clamp01(PowOrShortcut(Redistribute(PowOrShortcut(hyab, kQc), cmax), 1.0f - FeatureTerm(featureDiff)));
}

// The colour pipeline's cmax: the largest HyAB distance of the unit RGB cube (green vs blue), to the power q_c.
float MaxHyabPow();  // sim/metrics/flip_passes.cpp

// --- Filters ---------------------------------------------------------------------------------------------------

// A 1D kernel of 2 radius + 1 taps, applied as a correlation: out(x) = sum_t w[t] in(x - radius + t).
struct Kernel {
  int radius = 0;
  std::vector<float> w;
};

struct FlipKernels {
  int csfRadius = 0, featureRadius = 0, pad = 0;
  Kernel achromatic, redGreen, blueYellow1, blueYellow2;  // normalised Gaussians
  float blueYellowWeight1 = 1.0f, blueYellowWeight2 = 0.0f;
  Kernel gauss, edge, point;  // feature detectors: Gaussian, its first and second derivatives

  explicit FlipKernels(double ppd);  // sim/metrics/flip_passes.cpp
};

// Row buffers hold a multiple of this many floats (the widest SIMD target's lanes), so the SIMD stages run whole
// vectors; the lanes past the image width carry values nothing reads.
constexpr int kRowAlign = 16;
inline int RowStride(int width) { return (width + kRowAlign - 1) / kRowAlign * kRowAlign; }

// Buffers of rows start on 64-byte boundaries (kRowAlign floats), so the vertical pass's loads, at the same
// column of different rows, are aligned: unaligned 64-byte loads cost about half again as much. Buffers of
// kHugeBytes and more (a FlipReference's planes, HdrFlip's per-block differences) are asked for in 2 MB pages:
// allocated afresh for every frame, in 4 KB pages their page faults cost about a fifth of building the reference.
// Elements are left uninitialised (every row is written before it is read), which saves zeroing them.
void* AllocateRows(size_t bytes);  // sim/metrics/flip_passes.cpp
void FreeRows(void* p, size_t bytes);
template <class T>
struct AlignedAllocator {
  using value_type = T;
  AlignedAllocator() = default;
  template <class U>
  AlignedAllocator(const AlignedAllocator<U>&) {}
  T* allocate(size_t n) { return static_cast<T*>(AllocateRows(n * sizeof(T))); }
  void deallocate(T* p, size_t n) { FreeRows(p, n * sizeof(T)); }
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;  // default-initialised: no zeroing
  }
  template <class U, class A, class... Rest>
  void construct(U* p, A&& a, Rest&&... rest) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a), std::forward<Rest>(rest)...);
  }
  template <class U>
  bool operator==(const AlignedAllocator<U>&) const { return true; }
};
using AlignedFloats = std::vector<float, AlignedAllocator<float>>;

// The per-pixel results of one image after both filter passes, one row each: Hunt-adjusted L*a*b* (of the
// CSF-filtered colour) and the edge and point magnitudes of the achromatic channel.
enum FeaturePlane { kFeatL, kFeatA, kFeatB, kFeatEdge, kFeatPoint, kFeaturePlanes };

// A FlipReference's planes: [exposure][FeaturePlane][row][stride].
struct ReferencePlanes {
  int stride = 0;
  AlignedFloats values;
  const float* Row(int exposure, int plane, int y, int height) const {
    return values.data() + ((size_t(exposure) * kFeaturePlanes + plane) * height + y) * stride;
  }
};

// After the vertical pass: the CSF-filtered Y, Cx and both Cz terms; d/dx and d/dy of the edge detector; d²/dx²
// and d²/dy² of the point detector.
enum FilteredPlane { kFiltY, kFiltCx, kFiltCz1, kFiltCz2, kFiltEx, kFiltEy, kFiltPx, kFiltPy, kFilteredPlanes };

// --- Per-row stages (sim/metrics/flip_rows.cpp: Highway, dispatched to the best target)
// --------------------------------

// Pixels [0, width) of an interleaved RGB row -> YCxCz and the feature pipeline's luminance (Y + 16) / 116.
// toneMapScale > 0: each channel first goes through ToneMapX(scale * value) rounded to float (HDR-FLIP's
// exposure); otherwise each is clamped to [0, 1] (LDR-FLIP).
void PrepareRow(const float* rgb, int width, double toneMapScale, float* yy, float* cx, float* cz, float* lum);

// out[x] = sum over t of w[t] src[t][x], summed in tap order, for x in [0, count), count a multiple of kRowAlign.
// With `centre`: sum over t != skip of w[t] (src[t][x] - centre[x]), from 0 (the zero-sum derivative detectors:
// the same sum mathematically, and exactly 0 on a flat neighbourhood).
void CorrelateRow(const float* const* src, const float* w, int taps, const float* centre, int skip, int count,
                  float* out);

// CorrelateRow of several kernels of one radius over the same rows, in one sweep: out[k] with w[k], the first
// `plain` kernels plain, the next `centred` ones centred on `centre` (skipping tap `skip`). Bit for bit the
// separate CorrelateRow calls. Supported (plain, centred): (1, 0), (0, 1), (2, 0), (0, 2), (1, 2).
void CorrelateRows(const float* const* src, const float* const* w, int plain, int centred, int taps,
                   const float* centre, int skip, int count, float* const* out);

// The filtered planes of a row -> its FeaturePlane rows, for x in [0, count) (a multiple of kRowAlign).
void FeatureRow(const float* const* filtered, float blueYellowWeight1, float blueYellowWeight2, int count,
                float* const* features);

// For x in [0, count): HyAB of the two rows' colours (reference minus test) and the feature difference
// max(|Δedge|, |Δpoint|).
void DifferenceRow(const float* const* reference, const float* const* test, int count, float* hyab,
                   float* featureDiff);

// HDR-FLIP keeps the largest value over the exposures; the two pow calls per exposure were most of its cost. So
// each exposure first gets bounds lo <= ln(value) <= hi from a cheap approximation, and only the exposures whose
// hi reaches the largest lo are evaluated exactly (FlipFromDifferences): the others are provably below the
// maximum, which is therefore the same bits. The approximation (float log, exp and sqrt, <= 4 ulp each) errs by
// under 1e-4 in ln(value) against glibc's exact-to-an-ulp powf, a twentieth of the margin the bounds allow
// (kFlipBoundMargin); below kFlipBoundTiny the bounds are left open.
constexpr float kFlipBoundMargin = 1.0f / 512.0f;
constexpr float kFlipBoundTiny = 1e-30f;

// For x in [0, count) (a multiple of kRowAlign) and each exposure e < exposures, whose rows start at
// e * exposureStride in hyab and featureDiff: hi[e * count + x] the upper bound on ln(value), maxLo[x] the largest
// lower bound.
void BoundsRow(const float* hyab, const float* featureDiff, size_t exposureStride, int exposures, int count,
               float cmax, float* hi, float* maxLo);

// glibc 2.36's cbrtf, lane by lane (for the tests: the SIMD stages' copy of it, valid for positive normal floats).
void CbrtRow(const float* in, int count, float* out);

// --- The two filter passes over rows (sim/metrics/flip_passes.cpp) ---------------------------------------------------

// The horizontal pass's output planes.
enum HorizontalPlane { kHorY, kHorCx, kHorCz1, kHorCz2, kHorGauss, kHorEdge, kHorPoint, kHorizontalPlanes };

// One thread's buffers for Analyse: the padded source rows of the horizontal pass, the last 2 pad + 1 rows of its
// seven output planes (a ring: row r in slot r mod (2 pad + 1), all the vertical pass reaches), the vertical
// pass's rows, the features, and four rows for the caller's comparison. The ring keeps the horizontal pass's output
// in the L2 cache while the vertical pass reads it.
struct Scratch {
  int stride = 0, pad = 0, ringRows = 0;
  AlignedFloats padded, ring, filtered, features, compare;
  std::vector<const float*> taps;

  Scratch(int width, int pad);
  float* Padded(int i) { return padded.data() + size_t(i) * (stride + 2 * pad); }
  float* Ring(int plane, int row) { return ring.data() + (size_t(plane) * ringRows + row % ringRows) * stride; }
  float* Filtered(int plane) { return filtered.data() + size_t(plane) * stride; }
  float* Feature(int plane) { return features.data() + size_t(plane) * stride; }
  float* Compare(int i) { return compare.data() + size_t(i) * stride; }
};

// Horizontal pass of image row y into the ring: colour transform (tone-mapped with `scale` > 0, clamped to [0, 1]
// otherwise), replicated borders, the seven horizontal filters.
void HorizontalRow(const ImageRgb& image, const FlipKernels& k, double scale, int y, Scratch& s);

// Vertical pass of row y from the ring (rows clamped to the image: replicated border), then the per-pixel colour
// and feature magnitudes into s.Feature.
void VerticalRow(const FlipKernels& k, int height, int y, Scratch& s);

// Rows [y0, y1) of `image` through both passes at one tone (scale > 0: that exposure; 0: LDR clamp); after each
// row, onRow(y) reads the row's features from s.Feature.
template <class OnRow>
inline void Analyse(const ImageRgb& image, const FlipKernels& k, double scale, int y0, int y1, Scratch& s,
                    OnRow onRow) {
  const int h = image.height;
  int next = std::max(0, y0 - s.pad);  // the next row the horizontal pass has not done
  for (int y = y0; y < y1; ++y) {
    for (const int last = std::min(h - 1, y + s.pad); next <= last; ++next) HorizontalRow(image, k, scale, next, s);
    VerticalRow(k, h, y, s);
    onRow(y);
  }
}

}  // namespace restir::flip_detail
