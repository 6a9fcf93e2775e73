// sim/assets/texture.h's bilinear lookup against OpenGL's definition, written here from the specification and not from
// the implementation (OpenGL 4.6 core, section 8.14.2 "Coordinate Wrapping and Texel Selection", table 8.20):
// i0 = wrap(floor(u' - 1/2)), i1 = wrap(i0 + 1), alpha = frac(u' - 1/2), u' = size × s, with
//   REPEAT           wrap(i) = i mod size
//   CLAMP_TO_EDGE    wrap(i) = clamp(i, 0, size - 1)
//   MIRRORED_REPEAT  wrap(i) = (size - 1) - mirror((i mod 2size) - size), mirror(a) = a >= 0 ? a : -(1 + a)
// (the spec's formula for i; OpenGL's t runs from the image's first row, the simulator's v from its last, so
// t = 1 - v). A 5 × 3 texture whose every texel differs, every pair of wrap modes, coordinates from -3.3 to 3.3
// and near huge values, in double here; the implementation filters in float, so agreement is to 1e-5 relative.
#include "sim/assets/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>

namespace restir {
namespace {

int64_t SpecWrap(int64_t i, int64_t size, TextureWrap mode) {
  auto mod = [](int64_t a, int64_t b) { return ((a % b) + b) % b; };
  switch (mode) {
    case TextureWrap::kRepeat:
      return mod(i, size);
    case TextureWrap::kClampToEdge:
      return i < 0 ? 0 : i > size - 1 ? size - 1 : i;
    case TextureWrap::kMirroredRepeat: {
      const int64_t a = mod(i, 2 * size) - size;
      return (size - 1) - (a >= 0 ? a : -(1 + a));
    }
  }
  return 0;
}

glm::dvec3 SpecTexel(const Texture& t, int64_t x, int64_t y) {
  const size_t i = 3 * (size_t(SpecWrap(y, t.height, t.wrapV)) * t.width + size_t(SpecWrap(x, t.width, t.wrapU)));
  return {t.rgb[i], t.rgb[i + 1], t.rgb[i + 2]};
}

glm::dvec3 SpecSample(const Texture& t, double u, double v) {
  const double x = u * t.width - 0.5, y = (1.0 - v) * t.height - 0.5;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double a = x - x0, b = y - y0;
  const int64_t i = int64_t(x0), j = int64_t(y0);
  return (1 - a) * (1 - b) * SpecTexel(t, i, j) + a * (1 - b) * SpecTexel(t, i + 1, j) +
         (1 - a) * b * SpecTexel(t, i, j + 1) + a * b * SpecTexel(t, i + 1, j + 1);
}

Texture Distinct(TextureWrap u, TextureWrap v) {
  Texture t;
  t.name = "distinct";
  t.width = 5;
  t.height = 3;
  for (int k = 0; k < 15; ++k) {
    t.rgb.push_back(1.0f + k);
    t.rgb.push_back(0.5f + 0.25f * k * k);
    t.rgb.push_back(20.0f - k);
  }
  t.wrapU = u;
  t.wrapV = v;
  return t;
}

const char* Name(TextureWrap w) {
  return w == TextureWrap::kRepeat ? "REPEAT" : w == TextureWrap::kClampToEdge ? "CLAMP_TO_EDGE" : "MIRRORED_REPEAT";
}

TEST(Texture, BilinearLookupWrapsAsOpenGlDefinesIt) {
  const TextureWrap modes[3] = {TextureWrap::kRepeat, TextureWrap::kClampToEdge, TextureWrap::kMirroredRepeat};
  int checked = 0;
  for (TextureWrap wu : modes)
    for (TextureWrap wv : modes) {
      const Texture t = Distinct(wu, wv);
      SCOPED_TRACE(std::string(Name(wu)) + " x " + Name(wv));
      // Steps that are not multiples of a texel, so taps land everywhere between centres, edges included.
      for (int a = -66; a <= 66; ++a)
        for (int b = -66; b <= 66; ++b) {
          const float u = 0.05f * a + 0.0123f, v = 0.05f * b - 0.0071f;
          const glm::dvec3 want = SpecSample(t, u, v);
          const Vec3 got = SampleBilinear(t, u, v);
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(got[c], want[c], 1e-5 * std::fabs(want[c]) + 1e-6) << "u " << u << " v " << v << " ch " << c;
          ++checked;
        }
    }
  EXPECT_EQ(checked, 9 * 133 * 133);
}

// Far from the origin the lookup must keep the coordinate's position within its period (repeat: 1, mirrored: 2)
// and clamp to the edge. The formula above, evaluated in double at such coordinates, would itself round away the
// half texel (at 1e15 x 5 texels the spacing of doubles is 1), so the expected value is the formula's at the
// coordinate shifted by a whole number of periods of both modes, exactly (fmod by 2 is exact), or, clamped, at
// -1 or 2 (beyond which every tap is the edge texel). 1000.3 and -999.7 lie 0.3 past a period; 1e15 and -3e15
// are whole even numbers (floats that large are).
TEST(Texture, BilinearLookupKeepsTheFractionOfLargeCoordinates) {
  const TextureWrap modes[3] = {TextureWrap::kRepeat, TextureWrap::kClampToEdge, TextureWrap::kMirroredRepeat};
  for (TextureWrap w : modes) {
    const Texture t = Distinct(w, w);
    SCOPED_TRACE(Name(w));
    for (const float big : {1000.3f, -999.7f, 2.0e6f + 0.25f, 1.0e15f, -3.0e15f}) {
      const double near = w == TextureWrap::kClampToEdge ? (big > 0 ? 2.0 : -1.0) : std::fmod(double(big), 2.0);
      const glm::dvec3 want = SpecSample(t, near, near);
      const Vec3 got = SampleBilinear(t, big, big);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-4 * std::fabs(want[c])) << big;
    }
  }
}

}  // namespace
}  // namespace restir
