// sim/flip*.cpp against the pre-optimisation implementation (tests/sim/metrics/flip_legacy.h): HdrFlip, in its one-call
// and its FlipReference form, and LdrFlip must give the same maps bit for bit (memcmp of the floats) on odd sizes,
// empty images, non-finite and negative inputs, black and mostly black references, twelve orders of magnitude,
// several kernel sizes, one FlipReference for several images, one and two threads, and every SIMD target this
// machine runs. Golden hashes of whole runs include the FLIP maps, so "close" is not enough. Then the pieces the
// bit-identity rests on: the cube root copied from glibc, sqrt for pow(d, 0.5), the pow calls skipped, the
// constant cmax and the bounds that choose which exposures are evaluated exactly.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "flip_legacy.h"
#include "hwy/highway.h"
#include "hwy/targets.h"
#include "sim/metrics/flip.h"
#include "sim/metrics/flip_internal.h"

namespace restir {
namespace {

// Radiance 10^lo .. 10^hi, a share of exact zeros.
ImageRgb RandomHdr(int w, int h, uint32_t seed, float lo = -4.0f, float hi = 4.0f, float zeros = 0.05f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> e(lo, hi), u(0.0f, 1.0f);
  ImageRgb img(w, h);
  for (Vec3& p : img.pixels) {
    const float s = std::pow(10.0f, e(rng));
    p = u(rng) < zeros ? Vec3(0.0f) : Vec3(s * u(rng), s * u(rng), s * u(rng));
  }
  return img;
}

// Every fifth pixel gets a NaN, an infinity or a negative value in one channel.
ImageRgb WithNonFinite(ImageRgb img, uint32_t seed) {
  std::mt19937 rng(seed);
  const float odd[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity(), -1.0f, -1e-30f, -0.0f,
                       std::numeric_limits<float>::max(), std::numeric_limits<float>::denorm_min()};
  for (size_t i = 0; i < img.Size(); i += 5) img.pixels[i][int(rng() % 3)] = odd[rng() % 8];
  return img;
}

ImageRgb RandomLdr(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);  // some values outside [0, 1], clamped by LDR-FLIP
  ImageRgb img(w, h);
  for (Vec3& p : img.pixels) p = Vec3(u(rng), u(rng), u(rng));
  return img;
}

bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

size_t DifferingPixels(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  return n;
}

bool SameRange(const FlipExposureRange& a, const FlipExposureRange& b) {
  return std::memcmp(&a.start, &b.start, sizeof(double)) == 0 && std::memcmp(&a.stop, &b.stop, sizeof(double)) == 0 &&
         a.count == b.count;
}

// Every Highway target this binary has and this CPU runs (the emulated and scalar ones included), best first.
std::vector<int64_t> DispatchTargets() {
  hwy::SetSupportedTargetsForTest(0);
  std::vector<int64_t> targets;
  for (int64_t bits = hwy::SupportedTargets() & HWY_TARGETS; bits != 0; bits &= bits - 1)
    targets.push_back(bits & -bits);
  return targets;
}

// Restricts Highway's dispatch to one target for the scope (0: none), as restir-sim's --simd does.
class DispatchTo {
 public:
  explicit DispatchTo(int64_t target) { Set(target); }
  ~DispatchTo() { Set(0); }

 private:
  static void Set(int64_t target) {
    hwy::SetSupportedTargetsForTest(target);
    hwy::GetChosenTarget().Update(hwy::SupportedTargets());
  }
};

// The legacy maps of `tests` against `reference`, then today's at 1 and 2 threads and on every SIMD target (or
// the best only), in both forms; one FlipReference serves every test image.
void ExpectHdrLikeLegacy(const ImageRgb& reference, const std::vector<ImageRgb>& tests, double ppd,
                         const std::string& what, bool everyTarget = true) {
  std::vector<FlipMap> legacy;
  FlipExposureRange legacyRange;
  for (const ImageRgb& t : tests) legacy.push_back(legacy_flip::HdrFlip(reference, t, ppd, &legacyRange));
  std::vector<int64_t> targets = DispatchTargets();
  if (!everyTarget) targets.resize(1);
  for (int64_t target : targets) {
    for (int threads : {1, 2}) {
      const DispatchTo dispatch(target);
      tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
      const FlipReference prepared(reference, ppd);
      EXPECT_TRUE(SameRange(prepared.Range(), legacyRange)) << what;
      for (size_t i = 0; i < tests.size(); ++i) {
        const std::string where = what + ", test image " + std::to_string(i) + ", " + std::to_string(threads) +
                                  " thread(s), " + hwy::TargetName(target);
        FlipExposureRange r1, r2;
        const FlipMap viaPrepared = HdrFlip(prepared, tests[i], &r1);
        const FlipMap oneCall = HdrFlip(reference, tests[i], ppd, &r2);
        EXPECT_EQ(viaPrepared.width, legacy[i].width) << where;
        EXPECT_EQ(viaPrepared.height, legacy[i].height) << where;
        EXPECT_TRUE(SameBits(viaPrepared.values, legacy[i].values))
            << where << ": FlipReference form differs in " << DifferingPixels(viaPrepared.values, legacy[i].values)
            << " pixels";
        EXPECT_TRUE(SameBits(oneCall.values, legacy[i].values))
            << where << ": one-call form differs in " << DifferingPixels(oneCall.values, legacy[i].values)
            << " pixels";
        EXPECT_TRUE(SameRange(r1, legacyRange)) << where;
        EXPECT_TRUE(SameRange(r2, legacyRange)) << where;
      }
    }
  }
}

TEST(FlipLegacy, HdrFlipMatchesOnRandomImagesOfOddSizes) {
  uint32_t seed = 100;
  for (auto [w, h] : {std::pair{1, 1}, {7, 3}, {33, 17}, {17, 33}, {70, 41}}) {
    const ImageRgb ref = RandomHdr(w, h, seed++);
    ExpectHdrLikeLegacy(ref, {RandomHdr(w, h, seed++), RandomHdr(w, h, seed++), ref},
                        kFlipDefaultPpd, std::to_string(w) + "x" + std::to_string(h));
  }
}

TEST(FlipLegacy, EmptyImagesGiveEmptyMapsAsBefore) {
  for (auto [w, h] : {std::pair{0, 0}, {0, 5}, {5, 0}}) {
    const ImageRgb empty(w, h);
    FlipExposureRange legacyRange, range;
    const FlipMap legacy = legacy_flip::HdrFlip(empty, empty, kFlipDefaultPpd, &legacyRange);
    const FlipMap now = HdrFlip(FlipReference(empty), empty, &range);
    EXPECT_EQ(now.width, legacy.width);
    EXPECT_EQ(now.height, legacy.height);
    EXPECT_TRUE(now.values.empty() && legacy.values.empty());
    EXPECT_TRUE(SameRange(range, legacyRange));
    EXPECT_TRUE(LdrFlipWithComponents(empty, empty).flip.values.empty());
  }
}

TEST(FlipLegacy, HdrFlipMatchesAt640x360WithOneReferenceForSeveralImages) {
  const ImageRgb ref = RandomHdr(640, 360, 1);
  std::vector<ImageRgb> tests{RandomHdr(640, 360, 2), RandomHdr(640, 360, 3, -2.0f, 2.0f, 0.0f)};
  // A noisy estimate of the reference, as a preset's image is.
  ImageRgb noisy = ref;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  for (Vec3& p : noisy.pixels) p = Vec3(p.x * u(rng), p.y * u(rng), p.z * u(rng));
  tests.push_back(noisy);
  ExpectHdrLikeLegacy(ref, tests, kFlipDefaultPpd, "640x360", /*everyTarget=*/false);
}

TEST(FlipLegacy, HdrFlipMatchesWithNaNInfinityAndNegativeValues) {
  const ImageRgb ref = RandomHdr(45, 29, 10), test = RandomHdr(45, 29, 11);
  ExpectHdrLikeLegacy(WithNonFinite(ref, 12), {WithNonFinite(test, 13), test}, kFlipDefaultPpd, "non-finite reference");
  ExpectHdrLikeLegacy(ref, {WithNonFinite(test, 14)}, kFlipDefaultPpd, "non-finite test");
  ImageRgb infinite(9, 5);
  for (Vec3& p : infinite.pixels) p = Vec3(std::numeric_limits<float>::infinity());
  ExpectHdrLikeLegacy(infinite, {RandomHdr(9, 5, 15), infinite}, kFlipDefaultPpd, "all-infinite reference");
}

TEST(FlipLegacy, HdrFlipMatchesWithBlackAndMostlyBlackReferences) {
  const ImageRgb black(38, 21);
  ExpectHdrLikeLegacy(black, {RandomHdr(38, 21, 20), black}, kFlipDefaultPpd, "black reference");
  ExpectHdrLikeLegacy(RandomHdr(38, 21, 21, -4.0f, 4.0f, 0.8f), {RandomHdr(38, 21, 22), black}, kFlipDefaultPpd,
                      "mostly black reference");
}

TEST(FlipLegacy, HdrFlipMatchesOverTwelveOrdersOfMagnitude) {
  const ImageRgb ref = RandomHdr(61, 37, 30, -6.0f, 6.0f);
  FlipExposureRange range;
  legacy_flip::HdrFlip(ref, ref, kFlipDefaultPpd, &range);
  EXPECT_GE(range.count, 15);
  ExpectHdrLikeLegacy(ref, {RandomHdr(61, 37, 31, -6.0f, 6.0f), RandomHdr(61, 37, 32, -1.0f, 1.0f)},
                      kFlipDefaultPpd, "1e-6 .. 1e6");
}

TEST(FlipLegacy, HdrFlipMatchesAtOtherViewingDistances) {
  // Other ppd give other kernel radii (the CSF and the feature detectors' pads differ).
  for (double ppd : {12.0, 30.0, 150.0}) {
    const ImageRgb ref = RandomHdr(53, 31, 40);
    ExpectHdrLikeLegacy(ref, {RandomHdr(53, 31, 41)}, ppd, "ppd " + std::to_string(ppd));
  }
}

TEST(FlipLegacy, LdrFlipMatchesWithItsComponents) {
  for (auto [w, h] : {std::pair{1, 1}, {7, 3}, {33, 17}, {160, 90}}) {
    const ImageRgb a = RandomLdr(w, h, uint32_t(w * 7 + h)), b = RandomLdr(w, h, uint32_t(w * 11 + h));
    const LdrFlipComponents legacy = legacy_flip::LdrFlipWithComponents(a, b);
    for (int64_t target : DispatchTargets()) {
      for (int threads : {1, 2}) {
        const DispatchTo dispatch(target);
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        const LdrFlipComponents now = LdrFlipWithComponents(a, b);
        const std::string where = std::to_string(w) + "x" + std::to_string(h) + ", " + std::to_string(threads) +
                                  " thread(s), " + hwy::TargetName(target);
        EXPECT_TRUE(SameBits(now.flip.values, legacy.flip.values)) << where;
        EXPECT_TRUE(SameBits(now.color, legacy.color)) << where;
        EXPECT_TRUE(SameBits(now.feature, legacy.feature)) << where;
      }
    }
  }
}

// The SIMD stages' replacements for two libm calls, on the inputs FLIP can give them. (Checked exhaustively
// once, outside the suite: the cube root over every positive normal float, the square root over every
// non-negative float featureDiff, against glibc 2.36's FMA and SSE2 pow.)
TEST(FlipLegacy, CubeRootReplicatesTheCLibraryOverLabsRange) {
  // Lab's f(t) takes the cube root of t in ((6/29)^3, 1.09]: every float there, then every 997th positive normal.
  std::vector<float> in;
  for (float t = std::nextafter(flip_detail::kLabDeltaCube, 1.0f); t <= 1.1f; t = std::nextafter(t, 2.0f))
    in.push_back(t);
  for (uint32_t b = 0x00800000u; b < 0x7f800000u; b += 997) {
    float f;
    std::memcpy(&f, &b, sizeof f);
    in.push_back(f);
  }
  in.resize((in.size() + flip_detail::kRowAlign - 1) / flip_detail::kRowAlign * flip_detail::kRowAlign, 1.0f);
  std::vector<float> expected(in.size()), out(in.size());
  for (size_t i = 0; i < in.size(); ++i) expected[i] = std::cbrt(in[i]);
  for (int64_t target : DispatchTargets()) {
    const DispatchTo dispatch(target);
    flip_detail::CbrtRow(in.data(), static_cast<int>(in.size()), out.data());
    size_t bad = 0;
    for (size_t i = 0; i < in.size(); ++i)
      if (std::memcmp(&out[i], &expected[i], sizeof(float)) != 0 && bad++ < 5)
        ADD_FAILURE() << hwy::TargetName(target) << ": cbrt(" << in[i] << ") " << out[i] << " instead of "
                      << expected[i];
    EXPECT_EQ(bad, 0u) << hwy::TargetName(target);
  }
}

TEST(FlipLegacy, FeatureSquareRootEqualsThePowItReplaces) {
  // featureDiff is a difference of magnitudes of filtered values in [0, 1]: every 13th float in [0, 4).
  size_t bad = 0;
  for (uint32_t b = 0; b < 0x40800000u; b += 13) {
    float d;
    std::memcpy(&d, &b, sizeof d);
    const float viaPow = std::min(1.0f, static_cast<float>(std::pow(double(d) / std::sqrt(2.0), 0.5)));
    const float viaSqrt = flip_detail::FeatureTerm(d);
    if (std::memcmp(&viaPow, &viaSqrt, sizeof(float)) != 0 && bad++ < 5)
      ADD_FAILURE() << "featureDiff " << d << ": pow " << viaPow << ", sqrt " << viaSqrt;
  }
  EXPECT_EQ(bad, 0u);
}

TEST(FlipLegacy, PowShortcutsEqualTheCalls) {
  // 0^e, b^0 and b^1 for b, e in [0, 1]: every 7th float there (checked for every float once, outside the suite).
  size_t bad = 0;
  auto check = [&](float base, float exponent) {
    const float call = std::pow(base, exponent), shortcut = flip_detail::PowOrShortcut(base, exponent);
    if (std::memcmp(&call, &shortcut, sizeof(float)) != 0 && bad++ < 5)
      ADD_FAILURE() << base << "^" << exponent << ": " << call << " vs " << shortcut;
  };
  for (uint32_t b = 0; b <= 0x3f800000u; b += 7) {
    float v;
    std::memcpy(&v, &b, sizeof v);
    check(0.0f, v);
    check(v, 0.0f);
    check(v, 1.0f);
  }
  EXPECT_EQ(bad, 0u);
}

TEST(FlipLegacy, CmaxIsTheCorrectlyRoundedGamutDistance) {
  // Lab's f with a correctly rounded cube root (double cbrt, rounded once), then HyAB and a correctly rounded pow.
  auto lab = [](float r, float g, float b) {
    const flip_detail::Color3 xyz = flip_detail::MulMatrix(flip_detail::kRgbToXyz, r, g, b);
    float f[3];
    for (int c = 0; c < 3; ++c) {
      const float t = xyz.v[c] * flip_detail::kInvWhite[c];
      f[c] = t > flip_detail::kLabDeltaCube ? static_cast<float>(std::cbrt(double(t)))
                                            : flip_detail::kLabFactor * t + flip_detail::kLabOffset;
    }
    return flip_detail::Hunt({{116.0f * f[1] - 16.0f, 500.0f * (f[0] - f[1]), 200.0f * (f[1] - f[2])}});
  };
  volatile float one = 1.0f;  // evaluated here, at run time, whatever the compiler folds
  const float hyab = flip_detail::HyAB(lab(0.0f, one, 0.0f), lab(0.0f, 0.0f, one));
  const float cmax = static_cast<float>(std::pow(double(hyab), double(flip_detail::kQc)));
  EXPECT_EQ(cmax, flip_detail::MaxHyabPow());
  EXPECT_EQ(cmax, legacy_flip::MaxHyabPow());
}

// The bounds that pick which exposures HdrFlip evaluates exactly must hold the exact value, with room to spare:
// lo <= ln(FlipFromDifferences) <= hi over HyAB from 0 to beyond the gamut and every feature difference, and the
// approximation inside them off by under a quarter of the margin.
TEST(FlipLegacy, CandidateBoundsHoldTheExactValueWithRoomToSpare) {
  const float cmax = flip_detail::MaxHyabPow();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> hyab, featureDiff;
  for (int i = 0; i < (1 << 20); ++i) {
    const int kind = i % 8;
    hyab.push_back(kind == 0 ? 0.0f : std::pow(10.0f, -32.0f + 35.0f * u(rng)));  // 0 and 1e-32 .. 1e3
    featureDiff.push_back(kind == 1 ? 0.0f : (kind == 2 ? 2.0f * u(rng) : u(rng) * u(rng)));
  }
  // The feature term's step to 1 (featureDiff near sqrt 2), with HyAB 0 (value 0^0 = 1 or 0^ex = 0) and not.
  const float step = std::sqrt(2.0f);
  for (int k = -64; k <= 64; ++k) {
    float d = step;
    for (int j = 0; j < std::abs(k); ++j) d = std::nextafter(d, k < 0 ? 0.0f : 2.0f);
    for (float h : {0.0f, 1e-3f, 1.0f, 30.0f}) {
      hyab.push_back(h);
      featureDiff.push_back(d);
    }
  }
  while (hyab.size() % flip_detail::kRowAlign) {
    hyab.push_back(1.0f);
    featureDiff.push_back(0.5f);
  }
  const int n = static_cast<int>(hyab.size());
  std::vector<double> exact(hyab.size());
  for (size_t i = 0; i < hyab.size(); ++i)
    exact[i] = std::log(double(flip_detail::FlipFromDifferences(hyab[i], featureDiff[i], cmax)));
  for (int64_t target : DispatchTargets()) {
    const DispatchTo dispatch(target);
    std::vector<float> hi(hyab.size()), lo(hyab.size());
    flip_detail::BoundsRow(hyab.data(), featureDiff.data(), 0, 1, n, cmax, hi.data(), lo.data());
    size_t bad = 0;
    double worst = 0.0;
    for (size_t i = 0; i < hyab.size(); ++i) {
      if (!(lo[i] <= exact[i] && exact[i] <= hi[i]) && bad++ < 5)
        ADD_FAILURE() << hwy::TargetName(target) << ": hyab " << hyab[i] << ", featureDiff " << featureDiff[i]
                      << ": ln value " << exact[i] << " outside [" << lo[i] << ", " << hi[i] << "]";
      if (std::isfinite(lo[i]) && std::isfinite(hi[i]))
        worst = std::max(worst, std::fabs(exact[i] - 0.5 * (double(lo[i]) + double(hi[i]))));
    }
    EXPECT_EQ(bad, 0u) << hwy::TargetName(target);
    EXPECT_LT(worst, flip_detail::kFlipBoundMargin / 4.0) << hwy::TargetName(target);
    std::printf("%s: largest approximation error in ln(value) %.3g (margin %.3g)\n", hwy::TargetName(target), worst,
                double(flip_detail::kFlipBoundMargin));
  }
}

}  // namespace
}  // namespace restir
