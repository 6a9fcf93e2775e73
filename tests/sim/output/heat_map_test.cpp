// The report's and the scrubber's colour maps: a pixel's relative error is its relmse term's root (a closed form on
// a grid of errors and references), and a map's RGB is its palette at the value's level.
#include "sim/output/heat_map.h"

#include <gtest/gtest.h>

#include <cmath>

namespace restir {
namespace {

TEST(PixelRelativeError, IsTheRootOfTheMeanOfEachChannelsRelmseTerm) {
  for (float e : {0.0f, 1e-4f, -0.3f, 2.0f, 1e3f})
    for (float r : {0.0f, 0.01f, 0.5f, 40.0f, 1e4f}) {
      const float ev[3] = {e, 0.5f * e, -e}, rv[3] = {r, 2.0f * r, 0.1f * r};
      double want = 0.0;
      for (int c = 0; c < 3; ++c) want += double(ev[c]) * ev[c] / (double(rv[c]) * rv[c] + 0.01);
      EXPECT_DOUBLE_EQ(PixelRelativeError(ev, rv), std::sqrt(want / 3.0)) << e << " " << r;
    }
}

TEST(HeatMap, RgbIsThePaletteAtTheValuesLevelWithNonFiniteAndOutOfRangeClamped) {
  const std::vector<double> v = {0.0, 1.0, 0.5, 0.25 / 255, 0.75 / 255, -3.0, 7.0, NAN, INFINITY, -INFINITY};
  const std::vector<unsigned char> want = {0, 255, 128, 0, 1, 0, 255, 255, 255, 255};
  EXPECT_EQ(HeatMapLevels(v), want);
  for (ColourMap map : {ColourMap::kInferno, ColourMap::kMagma}) {
    const auto palette = HeatMapPalette(map);
    const std::vector<unsigned char> rgb = HeatMapRgb(v, map);
    for (size_t i = 0; i < v.size(); ++i)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(rgb[3 * i + c], palette[3 * want[i] + c]);
    // The maps run from dark to bright: the palette's luminance grows from its first entry to its last.
    auto luma = [&](int k) { return 0.2126 * palette[3 * k] + 0.7152 * palette[3 * k + 1] + 0.0722 * palette[3 * k + 2]; };
    EXPECT_LT(luma(0), 10.0);
    EXPECT_GT(luma(255), 200.0);
    for (int k = 16; k < 256; k += 16) EXPECT_GT(luma(k), luma(k - 16)) << k;
  }
}

TEST(HeatMap, ErrorValuesOfAnEstimateAgainstItsReference) {
  ImageRgb est(2, 1), ref(2, 1);
  est.pixels[0] = Vec3(1.0f, 2.0f, 3.0f);
  ref.pixels[0] = Vec3(1.0f, 2.0f, 3.0f);
  est.pixels[1] = Vec3(0.2f, 0.0f, 0.0f);
  ref.pixels[1] = Vec3(0.0f, 0.0f, 0.0f);
  const std::vector<double> v = RelativeErrorValues(est, ref);
  EXPECT_EQ(v[0], 0.0);
  EXPECT_NEAR(v[1], std::sqrt(0.04 / 0.01 / 3.0), 1e-6);
}

}  // namespace
}  // namespace restir
