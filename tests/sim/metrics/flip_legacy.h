// The pre-optimisation HDR-FLIP implementation (sim/metrics/flip.cpp as of commit 11a10df), kept as the oracle for
// bit-identity: tests/sim/metrics/flip_legacy_test.cpp compares sim/metrics/flip.cpp's maps with these bit for bit, and
// bench/flip_bench.cpp times it as the "before". Do not edit the arithmetic: any change here weakens that proof.
// Header-only so that the tests and the benchmark compile it with the project's flags without a CMake change.
//
// Two changes keep this copy computing what sim/metrics/flip.cpp's own build computed, whatever the compiler decides in
// the file that includes it (the code is otherwise verbatim, but for namespace qualifications):
// - MaxHyabPow returns the constant that build folded it to. GCC evaluates the function at compile time when it
//   can see through it (cbrt and pow of constants, correctly rounded: 0x1.4a3572p+5); calling glibc's cbrtf at
//   run time instead gives one ulp less. The original object file (g++ 12.2, the project's release flags) holds
//   MaxHyabPow as a load of 0x42251ab9 = 0x1.4a3572p+5f.
// - FlipKernels' constructor is not inlined, so that a constant ppd in the caller cannot get its std::exp calls
//   folded (correctly rounded) where the original computed them with glibc at run time.
//
// One change of definition, made identically in sim/metrics/flip.cpp (issue 16, agreement with NVIDIA's FLIP): Median
// takes the upper of the two middle luminances for an even pixel count, as NVIDIA's FLIP does, where 11a10df
// averaged them. It changes the exposures HDR-FLIP evaluates, not the per-exposure arithmetic this oracle proves.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "sim/metrics/flip.h"

namespace restir::legacy_flip {

namespace {

constexpr double kPi = 3.14159265358979323846;

// --- Constants of the papers -------------------------------------------------------------------------------

// Colour pipeline (FLIP 2020, §4.1): exponent of the HyAB distance and the error redistribution.
constexpr float kQc = 0.7f;
constexpr float kPc = 0.4f;
constexpr float kPt = 0.95f;
// Feature pipeline (§4.2): exponent, and the peak-to-trough width of the edge detector in degrees.
constexpr double kQf = 0.5;
constexpr double kFeatureWidthDegrees = 0.082;

// Contrast sensitivity functions as sums of two Gaussians in the frequency domain (§4.1, Table 1):
// S(f) = a1 exp(-b1 f²) + a2 exp(-b2 f²), per opponent channel; b2 = 1e-5 only avoids a division by 0 where
// a2 = 0.
struct CsfParams {
  double a1, b1, a2, b2;
};
constexpr CsfParams kCsfAchromatic{1.0, 0.0047, 0.0, 1e-5};
constexpr CsfParams kCsfRedGreen{1.0, 0.0053, 0.0, 1e-5};
constexpr CsfParams kCsfBlueYellow{34.1, 0.04, 13.5, 0.025};

// HDR-FLIP's ACES tone mapper (Narkowicz's fit, with the fit's 0.6 pre-exposure folded in):
// t(x) = (k0 x² + k1 x + k2) / (k3 x² + k4 x + k5).
constexpr double kTm0 = 0.6 * 0.6 * 2.51, kTm1 = 0.6 * 0.03, kTm2 = 0.0;
constexpr double kTm3 = 0.6 * 0.6 * 2.43, kTm4 = 0.6 * 0.59, kTm5 = 0.14;
// Tone-mapped value the brightest pixel reaches at the start exposure and the median at the stop exposure.
constexpr double kToneTarget = 0.85;

// Linear sRGB <-> CIE XYZ (D65), and the D65 reference white.
constexpr float kRgbToXyz[3][3] = {{10135552.0f / 24577794.0f, 8788810.0f / 24577794.0f, 4435075.0f / 24577794.0f},
                                   {2613072.0f / 12288897.0f, 8788810.0f / 12288897.0f, 887015.0f / 12288897.0f},
                                   {1425312.0f / 73733382.0f, 8788810.0f / 73733382.0f, 70074185.0f / 73733382.0f}};
constexpr float kXyzToRgb[3][3] = {{3.241003275f, -1.537398934f, -0.498615861f},
                                   {-0.969224334f, 1.875930071f, 0.041554224f},
                                   {0.055639423f, -0.204011202f, 1.057148933f}};
constexpr float kWhite[3] = {0.950428545f, 1.0f, 1.088900371f};
constexpr float kInvWhite[3] = {1.052156925f, 1.0f, 0.918357670f};

// --- Colour spaces -------------------------------------------------------------------------------------------

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

inline Color3 YcxczToLinearRgb(float yy, float cx, float cz) {
  const float y = (yy + 16.0f) / 116.0f;
  const float x = y + cx / 500.0f;
  const float z = y - cz / 200.0f;
  return MulMatrix(kXyzToRgb, x * kWhite[0], y * kWhite[1], z * kWhite[2]);
}

// Linear RGB -> CIE L*a*b* (D65).
inline Color3 LinearRgbToLab(float r, float g, float b) {
  const Color3 xyz = MulMatrix(kRgbToXyz, r, g, b);
  constexpr float delta = 6.0f / 29.0f;
  constexpr float deltaCube = delta * delta * delta;
  constexpr float factor = 1.0f / (3.0f * delta * delta);
  float f[3];
  for (int c = 0; c < 3; ++c) {
    const float t = xyz.v[c] * kInvWhite[c];
    f[c] = t > deltaCube ? std::cbrt(t) : factor * t + 4.0f / 29.0f;
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

// Largest HyAB distance between two colours of the unit RGB cube in Hunt-adjusted L*a*b* (green vs blue), to
// the power q_c.
float MaxHyabPow() {
  // Originally std::pow(HyAB(Hunt(LinearRgbToLab(0, 1, 0)), Hunt(LinearRgbToLab(0, 0, 1))), kQc), which the
  // original build folded to this constant (see the top of the file).
  return 0x1.4a3572p+5f;
}

// Maps the exponentiated HyAB distance to [0, 1]: [0, p_c cmax) linearly onto [0, p_t), the rest onto [p_t, 1].
inline float Redistribute(float powHyab, float cmax) {
  const float pcCmax = kPc * cmax;
  const float e = powHyab < pcCmax ? (kPt / pcCmax) * powHyab
                                   : kPt + ((powHyab - pcCmax) / (cmax - pcCmax)) * (1.0f - kPt);
  return std::min(e, 1.0f);  // the paper's cmax is the gamut's largest distance; guard rounding only
}

inline float Clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }  // NaN -> 0

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

  [[gnu::noinline]] explicit FlipKernels(double ppd) {
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
};

// Planes of one image after the horizontal pass.
enum Plane { kPlaneY, kPlaneCx, kPlaneCz1, kPlaneCz2, kPlaneGauss, kPlaneEdge, kPlanePoint, kPlaneCount };

// Correlation of `taps` source rows with weights w: out[x] = sum_t w[t] src[t][x], summed in tap order. With
// `centre`, each term is w[t] (src[t][x] - centre[x]) and the tap `skip` is left out: a zero-sum kernel (the
// derivative detectors) applied that way is the same sum mathematically and exactly 0 on a flat neighbourhood.
// Pixels go in blocks whose accumulators stay in registers; the order of the sum is the same for every pixel.
template <class SourceRow>
void Correlate(SourceRow src, const float* w, int taps, const float* centre, int skip, int width,
               float* __restrict out) {
  constexpr int kBlock = 16;
  int x0 = 0;
  for (; x0 + kBlock <= width; x0 += kBlock) {
    float acc[kBlock];
    for (int i = 0; i < kBlock; ++i) acc[i] = 0.0f;
    if (!centre) {
      const float* s0 = src(0) + x0;
      for (int i = 0; i < kBlock; ++i) acc[i] = w[0] * s0[i];
      for (int t = 1; t < taps; ++t) {
        const float* st = src(t) + x0;
        const float wt = w[t];
        for (int i = 0; i < kBlock; ++i) acc[i] += wt * st[i];
      }
    } else {
      const float* c = centre + x0;
      for (int t = 0; t < taps; ++t) {
        if (t == skip) continue;
        const float* st = src(t) + x0;
        const float wt = w[t];
        for (int i = 0; i < kBlock; ++i) acc[i] += wt * (st[i] - c[i]);
      }
    }
    for (int i = 0; i < kBlock; ++i) out[x0 + i] = acc[i];
  }
  for (int x = x0; x < width; ++x) {
    float acc = 0.0f;
    if (!centre) {
      acc = w[0] * src(0)[x];
      for (int t = 1; t < taps; ++t) acc += w[t] * src(t)[x];
    } else {
      for (int t = 0; t < taps; ++t)
        if (t != skip) acc += w[t] * (src(t)[x] - centre[x]);
    }
    out[x] = acc;
  }
}

// Horizontal correlation of a row padded by `pad` replicated pixels on each side (zeroSum: see Correlate).
void CorrelateRow(const float* padded, int pad, int width, const Kernel& k, bool zeroSum, float* __restrict out) {
  const int r = k.radius;
  const float* base = padded + (pad - r);
  Correlate([base](int t) { return base + t; }, k.w.data(), 2 * r + 1, zeroSum ? padded + pad : nullptr, r, width,
            out);
}

// Vertical correlation at row y of a plane (rows clamped to the image: replicated border).
void CorrelateColumn(const float* plane, int width, int height, int y, const Kernel& k, bool zeroSum,
                     float* __restrict out) {
  const int r = k.radius;
  auto row = [=](int t) { return plane + static_cast<size_t>(std::clamp(y - r + t, 0, height - 1)) * width; };
  Correlate(row, k.w.data(), 2 * r + 1, zeroSum ? plane + static_cast<size_t>(y) * width : nullptr, r, width, out);
}

struct Workspace {
  std::array<std::array<std::vector<float>, kPlaneCount>, 2> planes;  // [image][plane]
  void Resize(size_t n) {
    for (auto& img : planes)
      for (auto& p : img) p.resize(n);
  }
};

// LDR-FLIP of two images whose pixels `prepare` maps to linear RGB in [0, 1]. For every pixel i it calls
// sink(i, flip, color, feature); rows go to threads, each pixel to exactly one call.
template <class Prepare, class Sink>
void LdrFlipCore(const ImageRgb& reference, const ImageRgb& test, const FlipKernels& k, float cmax,
                 Prepare prepare, Workspace& ws, Sink sink) {
  const int w = reference.width, h = reference.height;
  ws.Resize(static_cast<size_t>(w) * h);
  const ImageRgb* images[2] = {&reference, &test};
  const int pad = k.pad;

  // Pass 1, per row: colour transform (YCxCz and normalised luminance), then the horizontal filters.
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    const size_t padded = static_cast<size_t>(w) + 2 * pad;
    std::vector<float> yy(padded), cx(padded), cz(padded), lum(padded);
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int img = 0; img < 2; ++img) {
        const Vec3* src = images[img]->pixels.data() + static_cast<size_t>(y) * w;
        for (int x = 0; x < w; ++x) {
          const Vec3 c = prepare(src[x]);
          const Color3 o = LinearRgbToYcxcz(c.x, c.y, c.z);
          yy[x + pad] = o.v[0];
          cx[x + pad] = o.v[1];
          cz[x + pad] = o.v[2];
          lum[x + pad] = (o.v[0] + 16.0f) / 116.0f;  // the feature pipeline's achromatic channel, in [0, 1]
        }
        for (std::vector<float>* b : {&yy, &cx, &cz, &lum})
          for (int i = 0; i < pad; ++i) {
            (*b)[i] = (*b)[pad];
            (*b)[pad + w + i] = (*b)[pad + w - 1];
          }
        auto& p = ws.planes[img];
        const size_t o = static_cast<size_t>(y) * w;
        CorrelateRow(yy.data(), pad, w, k.achromatic, false, p[kPlaneY].data() + o);
        CorrelateRow(cx.data(), pad, w, k.redGreen, false, p[kPlaneCx].data() + o);
        CorrelateRow(cz.data(), pad, w, k.blueYellow1, false, p[kPlaneCz1].data() + o);
        CorrelateRow(cz.data(), pad, w, k.blueYellow2, false, p[kPlaneCz2].data() + o);
        CorrelateRow(lum.data(), pad, w, k.gauss, false, p[kPlaneGauss].data() + o);
        CorrelateRow(lum.data(), pad, w, k.edge, true, p[kPlaneEdge].data() + o);
        CorrelateRow(lum.data(), pad, w, k.point, true, p[kPlanePoint].data() + o);
      }
    }
  });

  // Pass 2, per row: vertical filters, then the colour and feature differences.
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    enum { kY, kCx, kCz1, kCz2, kEx, kEy, kPx, kPy, kCount };
    std::array<std::array<std::vector<float>, kCount>, 2> v;
    for (auto& img : v)
      for (auto& b : img) b.resize(w);
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int img = 0; img < 2; ++img) {
        const auto& p = ws.planes[img];
        auto& o = v[img];
        CorrelateColumn(p[kPlaneY].data(), w, h, y, k.achromatic, false, o[kY].data());
        CorrelateColumn(p[kPlaneCx].data(), w, h, y, k.redGreen, false, o[kCx].data());
        CorrelateColumn(p[kPlaneCz1].data(), w, h, y, k.blueYellow1, false, o[kCz1].data());
        CorrelateColumn(p[kPlaneCz2].data(), w, h, y, k.blueYellow2, false, o[kCz2].data());
        CorrelateColumn(p[kPlaneEdge].data(), w, h, y, k.gauss, false, o[kEx].data());   // d/dx, smoothed in y
        CorrelateColumn(p[kPlaneGauss].data(), w, h, y, k.edge, true, o[kEy].data());   // d/dy, smoothed in x
        CorrelateColumn(p[kPlanePoint].data(), w, h, y, k.gauss, false, o[kPx].data());  // d²/dx²
        CorrelateColumn(p[kPlaneGauss].data(), w, h, y, k.point, true, o[kPy].data());  // d²/dy²
      }
      for (int x = 0; x < w; ++x) {
        Color3 lab[2];
        float edgeMag[2], pointMag[2];
        for (int img = 0; img < 2; ++img) {
          const auto& o = v[img];
          const float czFiltered = k.blueYellowWeight1 * o[kCz1][x] + k.blueYellowWeight2 * o[kCz2][x];
          const Color3 rgb = YcxczToLinearRgb(o[kY][x], o[kCx][x], czFiltered);
          lab[img] = Hunt(LinearRgbToLab(Clamp01(rgb.v[0]), Clamp01(rgb.v[1]), Clamp01(rgb.v[2])));
          edgeMag[img] = std::sqrt(o[kEx][x] * o[kEx][x] + o[kEy][x] * o[kEy][x]);
          pointMag[img] = std::sqrt(o[kPx][x] * o[kPx][x] + o[kPy][x] * o[kPy][x]);
        }
        const float color = Redistribute(std::pow(HyAB(lab[0], lab[1]), kQc), cmax);
        const float featureDiff =
            std::max(std::fabs(edgeMag[0] - edgeMag[1]), std::fabs(pointMag[0] - pointMag[1]));
        const float feature =
            std::min(1.0f, static_cast<float>(std::pow(double(featureDiff) / std::sqrt(2.0), kQf)));
        const float flip = Clamp01(std::pow(color, 1.0f - feature));
        sink(static_cast<size_t>(y) * w + x, flip, color, feature);
      }
    }
  });
}

void CheckInputs(const ImageRgb& reference, const ImageRgb& test, double ppd) {
  if (reference.width != test.width || reference.height != test.height)
    throw std::invalid_argument("FLIP: reference and test images differ in size");
  if (reference.Size() != static_cast<size_t>(reference.width) * reference.height ||
      test.Size() != reference.Size())
    throw std::invalid_argument("FLIP: image pixel count does not match its size");
  if (!(ppd > 0.0) || !std::isfinite(ppd)) throw std::invalid_argument("FLIP: pixels per degree must be > 0");
}

double ToneMapX(double x) {
  if (!(x > 0.0)) return 0.0;   // negative and NaN
  if (x > 1e100) return 1.0;    // +inf and beyond the double range of x²: the curve's limit k0/k3 > 1 clamps to 1
  const double y = (kTm0 * x * x + kTm1 * x + kTm2) / (kTm3 * x * x + kTm4 * x + kTm5);
  return std::min(y, 1.0);
}

// x at which the tone mapper reaches t: the positive root of (k0 - k3 t) x² + (k1 - k4 t) x + (k2 - k5 t) = 0.
double ToneMapInverse(double t) {
  const double c0 = (kTm1 - kTm4 * t) / (kTm0 - kTm3 * t);
  const double c1 = (kTm2 - kTm5 * t) / (kTm0 - kTm3 * t);
  return -0.5 * c0 + std::sqrt(0.25 * c0 * c0 - c1);
}

// The median as NVIDIA's FLIP takes it (FLIP.h, computeExposures): the value at index n / 2 of the sorted values,
// so the upper of the two middle values for an even count. Averaging the two instead moves the stop exposure,
// hence every exposure, whenever they differ (issue 16: up to 0.033 in the mean on tests/data/flip_nvidia/).
double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

}  // namespace

inline float FlipSrgbToLinear(float v) {
  return v > 0.04045f ? std::pow((v + 0.055f) / 1.055f, 2.4f) : v / 12.92f;
}

inline float FlipAcesToneMap(float value, double exposure) {
  return static_cast<float>(ToneMapX(std::exp2(exposure) * double(value)));
}

inline FlipExposureRange FlipExposures(const ImageRgb& reference) {
  std::vector<double> lum;
  lum.reserve(reference.Size());
  double yMax = 0.0;
  for (const Vec3& p : reference.pixels) {
    auto channel = [](float c) { return c > 0.0f ? double(c) : 0.0; };  // negative and NaN count as 0
    const double y = 0.2126 * channel(p.x) + 0.7152 * channel(p.y) + 0.0722 * channel(p.z);
    if (!std::isfinite(y)) continue;  // +inf tone-maps to 1 at every exposure
    lum.push_back(y);
    yMax = std::max(yMax, y);
  }
  FlipExposureRange range;
  if (lum.empty() || yMax <= 0.0) return range;  // black reference: exposures 0 and 0
  double yMedian = Median(lum);
  if (yMedian <= 0.0) {
    lum.erase(std::remove_if(lum.begin(), lum.end(), [](double y) { return y <= 0.0; }), lum.end());
    yMedian = Median(lum);
  }
  const double xTarget = ToneMapInverse(kToneTarget);
  range.start = std::log2(xTarget / yMax);
  range.stop = std::log2(xTarget / yMedian);
  range.count = std::max(2, static_cast<int>(std::ceil(range.stop - range.start)));
  return range;
}

inline LdrFlipComponents LdrFlipWithComponents(const ImageRgb& reference, const ImageRgb& test,
                                               double ppd = kFlipDefaultPpd) {
  CheckInputs(reference, test, ppd);
  const FlipKernels kernels(ppd);
  const float cmax = MaxHyabPow();
  LdrFlipComponents out;
  out.flip.width = reference.width;
  out.flip.height = reference.height;
  out.flip.values.resize(reference.Size());
  out.color.resize(reference.Size());
  out.feature.resize(reference.Size());
  Workspace ws;
  LdrFlipCore(
      reference, test, kernels, cmax,
      [](const Vec3& c) { return Vec3(Clamp01(c.x), Clamp01(c.y), Clamp01(c.z)); }, ws,
      [&](size_t i, float flip, float color, float feature) {
        out.flip.values[i] = flip;
        out.color[i] = color;
        out.feature[i] = feature;
      });
  return out;
}

inline FlipMap LdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd) {
  return legacy_flip::LdrFlipWithComponents(reference, test, ppd).flip;
}

inline FlipMap HdrFlip(const ImageRgb& reference, const ImageRgb& test, double ppd = kFlipDefaultPpd,
                       FlipExposureRange* rangeOut = nullptr) {
  CheckInputs(reference, test, ppd);
  const FlipKernels kernels(ppd);
  const float cmax = MaxHyabPow();
  const FlipExposureRange range = legacy_flip::FlipExposures(reference);  // qualified: ADL also finds restir::
  if (rangeOut) *rangeOut = range;
  FlipMap out;
  out.width = reference.width;
  out.height = reference.height;
  out.values.assign(reference.Size(), 0.0f);
  Workspace ws;
  for (int e = 0; e < range.count; ++e) {
    const double scale = std::exp2(range.Exposure(e));
    LdrFlipCore(
        reference, test, kernels, cmax,
        [scale](const Vec3& c) {
          return Vec3(static_cast<float>(ToneMapX(scale * double(c.x))),
                      static_cast<float>(ToneMapX(scale * double(c.y))),
                      static_cast<float>(ToneMapX(scale * double(c.z))));
        },
        ws, [&](size_t i, float flip, float, float) { out.values[i] = std::max(out.values[i], flip); });
  }
  return out;
}

inline size_t HdrFlipScratchBytesPerPixel() {
  return 2 * kPlaneCount * sizeof(float) + sizeof(double);  // Workspace::planes, FlipExposures' luminances
}

inline double MeanFlip(const FlipMap& map, const std::vector<uint8_t>* mask) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < map.values.size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    sum += map.values[i];
    ++n;
  }
  return n ? sum / double(n) : 0.0;
}

}  // namespace restir::legacy_flip
