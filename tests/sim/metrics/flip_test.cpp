#include "sim/metrics/flip.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <random>

namespace restir {
namespace {

ImageRgb Flat(int w, int h, Vec3 c) {
  ImageRgb img(w, h);
  for (Vec3& p : img.pixels) p = c;
  return img;
}

ImageRgb RandomLdr(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ImageRgb img(w, h);
  for (Vec3& p : img.pixels) p = Vec3(u(rng), u(rng), u(rng));
  return img;
}

// Radiance spanning eight orders of magnitude (10^-4 .. 10^4), some exact zeros.
ImageRgb RandomHdr(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> e(-4.0f, 4.0f), u(0.0f, 1.0f);
  ImageRgb img(w, h);
  for (Vec3& p : img.pixels) {
    const float s = std::pow(10.0f, e(rng));
    p = u(rng) < 0.05f ? Vec3(0.0f) : Vec3(s * u(rng), s * u(rng), s * u(rng));
  }
  return img;
}

bool BitIdentical(const FlipMap& a, const FlipMap& b) {
  return a.values.size() == b.values.size() &&
         std::memcmp(a.values.data(), b.values.data(), a.values.size() * sizeof(float)) == 0;
}

// --- An independent double-precision evaluation of the colour pipeline on one colour pair (no filtering: on a
// flat field the CSF filters, which sum to 1, leave the colour unchanged). From the 2020 paper's definitions.
struct Lab {
  double l, a, b;
};
Lab HuntLab(double r, double g, double b) {
  const double x = (0.4123907993 * r + 0.3575843394 * g + 0.1804807884 * b) / 0.950428545;
  const double y = 0.2126390059 * r + 0.7151686788 * g + 0.0721923154 * b;
  const double z = (0.0193308187 * r + 0.1191947798 * g + 0.9505321522 * b) / 1.088900371;
  auto f = [](double t) {
    const double d = 6.0 / 29.0;
    return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
  };
  const double L = 116 * f(y) - 16;
  return {L, 0.01 * L * 500 * (f(x) - f(y)), 0.01 * L * 200 * (f(y) - f(z))};
}
double HyAB(const Lab& p, const Lab& q) { return std::abs(p.l - q.l) + std::hypot(p.a - q.a, p.b - q.b); }
double ExpectedColorError(Vec3 c1, Vec3 c2) {
  const double cmax = std::pow(HyAB(HuntLab(0, 1, 0), HuntLab(0, 0, 1)), 0.7);
  const double e = std::pow(HyAB(HuntLab(c1.x, c1.y, c1.z), HuntLab(c2.x, c2.y, c2.z)), 0.7);
  return e < 0.4 * cmax ? 0.95 / (0.4 * cmax) * e : 0.95 + (e - 0.4 * cmax) / (cmax - 0.4 * cmax) * 0.05;
}

TEST(Flip, DefaultViewingConditionsGiveAbout67PixelsPerDegree) {
  EXPECT_NEAR(kFlipDefaultPpd, 3840.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(kFlipDefaultPpd, 67.02, 0.01);
}

TEST(Flip, IdenticalImagesGiveExactlyZeroEverywhere) {
  const ImageRgb ldr = RandomLdr(37, 23, 1);
  for (float v : LdrFlip(ldr, ldr).values) ASSERT_EQ(v, 0.0f);
  const ImageRgb hdr = RandomHdr(37, 23, 2);
  for (float v : HdrFlip(hdr, hdr).values) ASSERT_EQ(v, 0.0f);
}

TEST(Flip, LdrValuesStayWithinUnitIntervalForRandomImages) {
  for (uint32_t s = 0; s < 3; ++s) {
    const FlipMap m = LdrFlip(RandomLdr(41, 29, 10 + s), RandomLdr(41, 29, 20 + s));
    double sum = 0.0;
    for (float v : m.values) {
      ASSERT_GE(v, 0.0f);
      ASSERT_LE(v, 1.0f);
      sum += v;
    }
    EXPECT_GT(sum / double(m.values.size()), 0.1);  // independent noise differs visibly
  }
}

TEST(Flip, HdrValuesStayWithinUnitIntervalAcrossOrdersOfMagnitude) {
  const ImageRgb ref = RandomHdr(41, 29, 3), test = RandomHdr(41, 29, 4);
  FlipExposureRange range;
  const FlipMap m = HdrFlip(ref, test, kFlipDefaultPpd, &range);
  EXPECT_GE(range.count, 10);  // from the brightest pixel (~1e4) down to the median (~1): many exposures
  for (float v : m.values) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
  // Non-finite and negative inputs are tolerated (they count as 0, +inf as white).
  ImageRgb odd = test;
  odd.pixels[0] = Vec3(NAN, -1.0f, INFINITY);
  for (float v : HdrFlip(ref, odd).values) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
}

TEST(Flip, BlackVersusWhiteIsCloseToOne) {
  const FlipMap m = LdrFlip(Flat(16, 16, Vec3(0.0f)), Flat(16, 16, Vec3(1.0f)));
  // HyAB = |100 - 0| = 100 > p_c cmax^(1/q_c): the redistribution's upper segment, about 0.967.
  const double expected = ExpectedColorError(Vec3(0.0f), Vec3(1.0f));
  EXPECT_GT(expected, 0.96);
  for (float v : m.values) EXPECT_NEAR(v, expected, 1e-5);
}

TEST(Flip, ColourOnlyDifferenceOnFlatFieldComesFromTheColourPipelineAlone) {
  // Equal luminance, different chromaticity: red-ish versus blue-green of the same Y.
  const Vec3 a(0.6f, 0.2f, 0.2f);
  const float ya = 0.2126f * a.x + 0.7152f * a.y + 0.0722f * a.z;
  const Vec3 b(0.1f, (ya - 0.2126f * 0.1f - 0.0722f * 0.5f) / 0.7152f, 0.5f);
  const LdrFlipComponents c = LdrFlipWithComponents(Flat(24, 18, a), Flat(24, 18, b));
  const double expected = ExpectedColorError(a, b);
  EXPECT_GT(expected, 0.3);
  for (size_t i = 0; i < c.flip.values.size(); ++i) {
    ASSERT_EQ(c.feature[i], 0.0f);               // no edges, no points
    ASSERT_EQ(c.flip.values[i], c.color[i]);     // ΔE_c^(1 - 0)
    ASSERT_NEAR(c.color[i], expected, 2e-5);     // the colour pipeline's value for the pair
  }
}

TEST(Flip, FeaturePipelineIsZeroOnFlatImages) {
  // Different levels, still flat: the edge and point detectors see nothing in either image.
  const LdrFlipComponents c = LdrFlipWithComponents(Flat(20, 20, Vec3(0.2f)), Flat(20, 20, Vec3(0.7f)));
  for (size_t i = 0; i < c.flip.values.size(); ++i) {
    ASSERT_EQ(c.feature[i], 0.0f);
    ASSERT_EQ(c.flip.values[i], c.color[i]);
    ASSERT_GT(c.color[i], 0.0f);
  }
}

TEST(Flip, EdgeInOneImageOnlyErrsMoreAlongTheEdgeThanAUniformShiftOfTheSameMean) {
  const int w = 64, h = 32;
  const float base = 0.2f, d = 0.05f;
  const ImageRgb ref = Flat(w, h, Vec3(base));
  ImageRgb edge = ref;  // right half brighter by 2d: mean difference d, and an edge at x = w / 2
  for (int y = 0; y < h; ++y)
    for (int x = w / 2; x < w; ++x) edge.pixels[size_t(y) * w + x] = Vec3(base + 2 * d);
  const ImageRgb shift = Flat(w, h, Vec3(base + d));  // same mean difference, no edge
  const LdrFlipComponents e = LdrFlipWithComponents(ref, edge);
  const LdrFlipComponents s = LdrFlipWithComponents(ref, shift);
  for (int y = 0; y < h; ++y) {
    for (int x : {w / 2 - 1, w / 2}) {
      const size_t i = size_t(y) * w + x;
      EXPECT_GT(e.feature[i], 0.1f) << x << "," << y;
      EXPECT_EQ(s.feature[i], 0.0f);
      EXPECT_GT(e.flip.values[i], s.flip.values[i]) << x << "," << y;
      EXPECT_GT(e.flip.values[i], e.color[i]);  // the feature term lifts the colour error
    }
  }
  // Far from the edge the feature pipeline is silent again.
  EXPECT_EQ(e.feature[size_t(h / 2) * w + 2], 0.0f);
}

TEST(Flip, LdrFlipIsSymmetricBitForBit) {
  const ImageRgb a = RandomLdr(33, 21, 5), b = RandomLdr(33, 21, 6);
  const LdrFlipComponents ab = LdrFlipWithComponents(a, b), ba = LdrFlipWithComponents(b, a);
  EXPECT_TRUE(BitIdentical(ab.flip, ba.flip));
  EXPECT_EQ(ab.color, ba.color);
  EXPECT_EQ(ab.feature, ba.feature);
}

TEST(Flip, HdrFlipTakesItsExposureRangeFromTheReference) {
  // Luminance: 60 pixels at Y = 1, 4 at Y = 15. Y_max = 15, Y_median = 1.
  ImageRgb ref = Flat(8, 8, Vec3(1.0f));
  for (int i = 0; i < 4; ++i) ref.pixels[size_t(i) * 9] = Vec3(15.0f);
  // x with ACES(x) = 0.85, from the quadratic (k0 - k3 t) x² + (k1 - k4 t) x - k5 t = 0.
  const double k0 = 0.36 * 2.51, k1 = 0.6 * 0.03, k3 = 0.36 * 2.43, k4 = 0.6 * 0.59, k5 = 0.14, t = 0.85;
  const double qa = k0 - k3 * t, qb = k1 - k4 * t, qc = -k5 * t;
  const double x85 = (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
  EXPECT_NEAR(FlipAcesToneMap(static_cast<float>(x85), 0.0), 0.85f, 1e-6);
  const FlipExposureRange r = FlipExposures(ref);
  EXPECT_NEAR(r.start, std::log2(x85 / 15.0), 1e-9);
  EXPECT_NEAR(r.stop, std::log2(x85 / 1.0), 1e-9);
  EXPECT_EQ(r.count, 4);  // max(2, ceil(stop - start)) = ceil(log2 15) = ceil(3.91)
  EXPECT_NEAR(r.Exposure(r.count - 1), r.stop, 1e-12);

  // So it is not symmetric: the other image as reference evaluates other exposures.
  ImageRgb test = ref;
  for (Vec3& p : test.pixels) p = p * 3.0f;
  test.pixels[5] = Vec3(100.0f, 10.0f, 1.0f);
  FlipExposureRange r1, r2;
  const FlipMap m1 = HdrFlip(ref, test, kFlipDefaultPpd, &r1), m2 = HdrFlip(test, ref, kFlipDefaultPpd, &r2);
  EXPECT_NE(r1.start, r2.start);
  EXPECT_FALSE(BitIdentical(m1, m2));
}

TEST(Flip, HdrFlipStopExposureTakesTheUpperMiddleLuminanceOfAnEvenCount) {
  // As NVIDIA's FLIP: with Y = 1, 2, 4, 8 the median is 4 (index n / 2 of the sorted values), not 3.
  ImageRgb ref(4, 1);
  for (int i = 0; i < 4; ++i) ref.pixels[size_t(i)] = Vec3(float(1 << (3 - i)));
  const FlipExposureRange r = FlipExposures(ref);
  EXPECT_NEAR(r.stop - r.start, std::log2(8.0 / 4.0), 1e-12);
  // Odd count: the middle value.
  ImageRgb odd(3, 1);
  for (int i = 0; i < 3; ++i) odd.pixels[size_t(i)] = Vec3(float(1 << i));
  const FlipExposureRange o = FlipExposures(odd);
  EXPECT_NEAR(o.stop - o.start, std::log2(4.0 / 2.0), 1e-12);
}

TEST(Flip, HdrFlipIsThePerPixelMaximumOfLdrFlipOverToneMappedExposures) {
  const ImageRgb ref = RandomHdr(19, 13, 7), test = RandomHdr(19, 13, 8);
  FlipExposureRange range;
  const FlipMap hdr = HdrFlip(ref, test, kFlipDefaultPpd, &range);
  ASSERT_GE(range.count, 2);
  std::vector<float> expected(ref.Size(), 0.0f);
  for (int e = 0; e < range.count; ++e) {
    ImageRgb tr(ref.width, ref.height), tt(ref.width, ref.height);
    for (size_t i = 0; i < ref.Size(); ++i)
      for (int c = 0; c < 3; ++c) {
        tr.pixels[i][c] = FlipAcesToneMap(ref.pixels[i][c], range.Exposure(e));
        tt.pixels[i][c] = FlipAcesToneMap(test.pixels[i][c], range.Exposure(e));
      }
    const FlipMap ldr = LdrFlip(tr, tt);
    for (size_t i = 0; i < expected.size(); ++i) expected[i] = std::max(expected[i], ldr.values[i]);
  }
  EXPECT_EQ(hdr.values, expected);
}

TEST(Flip, HdrFlipOfAnExposureScaledCopyIsNonZeroAndGrowsWithTheScale) {
  // HDR-FLIP compares the two images tone-mapped at the same exposures, so a global exposure change is a
  // visible difference (brightness), not something it normalises away.
  const ImageRgb ref = RandomHdr(32, 24, 9);
  auto scaled = [&](float k) {
    ImageRgb s = ref;
    for (Vec3& p : s.pixels) p = p * k;
    return s;
  };
  const double m1 = MeanFlip(HdrFlip(ref, scaled(1.0f)));
  const double m11 = MeanFlip(HdrFlip(ref, scaled(1.1f)));
  const double m2 = MeanFlip(HdrFlip(ref, scaled(2.0f)));
  const double m8 = MeanFlip(HdrFlip(ref, scaled(8.0f)));
  EXPECT_EQ(m1, 0.0);
  EXPECT_GT(m11, 0.01);
  EXPECT_LT(m11, m2);
  EXPECT_LT(m2, m8);
  EXPECT_LE(m8, 1.0);
  // Darkening is an error too.
  EXPECT_GT(MeanFlip(HdrFlip(ref, scaled(0.5f))), 0.05);
}

TEST(Flip, BitIdenticalAcrossOneAndTwoThreads) {
  const ImageRgb ref = RandomHdr(97, 61, 11), test = RandomHdr(97, 61, 12);
  FlipMap one, two;
  LdrFlipComponents ldrOne, ldrTwo;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = HdrFlip(ref, test);
    ldrOne = LdrFlipWithComponents(RandomLdr(97, 61, 13), RandomLdr(97, 61, 14));
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = HdrFlip(ref, test);
    ldrTwo = LdrFlipWithComponents(RandomLdr(97, 61, 13), RandomLdr(97, 61, 14));
  }
  EXPECT_TRUE(BitIdentical(one, two));
  EXPECT_TRUE(BitIdentical(ldrOne.flip, ldrTwo.flip));
  EXPECT_EQ(MeanFlip(one), MeanFlip(two));
}

TEST(Flip, MeanOverAMaskAveragesOnlySelectedPixels) {
  FlipMap m;
  m.width = 4;
  m.height = 1;
  m.values = {0.5f, 0.25f, 1.0f, 0.0f};
  EXPECT_DOUBLE_EQ(MeanFlip(m), 0.4375);
  const std::vector<uint8_t> mask{1, 0, 1, 0}, none(4, 0);
  EXPECT_DOUBLE_EQ(MeanFlip(m, &mask), 0.75);
  EXPECT_EQ(MeanFlip(m, &none), 0.0);
}

TEST(Flip, AcesToneMapperIsClampedAndMonotonic) {
  EXPECT_EQ(FlipAcesToneMap(0.0f, 0.0), 0.0f);
  EXPECT_EQ(FlipAcesToneMap(-1.0f, 0.0), 0.0f);
  EXPECT_EQ(FlipAcesToneMap(INFINITY, 0.0), 1.0f);
  EXPECT_EQ(FlipAcesToneMap(1e30f, 0.0), 1.0f);
  float prev = 0.0f;
  for (float x = 0.01f; x < 100.0f; x *= 1.5f) {
    const float t = FlipAcesToneMap(x, 0.0);
    EXPECT_GE(t, prev);
    prev = t;
  }
  EXPECT_EQ(FlipAcesToneMap(1.0f, 1.0), FlipAcesToneMap(2.0f, 0.0));  // exposure e scales by 2^e
}

TEST(Flip, MismatchedSizesAreRejected) {
  EXPECT_THROW(LdrFlip(ImageRgb(4, 4), ImageRgb(4, 5)), std::invalid_argument);
  EXPECT_THROW(HdrFlip(ImageRgb(4, 4), ImageRgb(5, 4)), std::invalid_argument);
}

}  // namespace
}  // namespace restir
