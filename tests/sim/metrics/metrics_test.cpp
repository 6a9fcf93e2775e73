#include "sim/metrics/metrics.h"

#include <gtest/gtest.h>

namespace restir {
namespace {

// Two 2x1 images with hand-computed answers.
TEST(Metrics, AccuracyMatchesHandComputedValues) {
  ImageRgb est(2, 1), ref(2, 1);
  est.pixels = {Vec3(1, 2, 3), Vec3(0, 0, 0)};
  ref.pixels = {Vec3(1, 1, 1), Vec3(0.5f, 0.5f, 0.5f)};
  const AccuracyMetrics m = MeasureAccuracy(est, ref);
  // Squared errors: 0, 1, 4, 0.25, 0.25, 0.25 -> mean 5.75 / 6.
  EXPECT_NEAR(m.rmse, std::sqrt(5.75 / 6.0), 1e-12);
  // relmse: 0/1.01 + 1/1.01 + 4/1.01 + 3 * 0.25/0.26, over 6.
  EXPECT_NEAR(m.relmse, (5.0 / 1.01 + 3 * 0.25 / 0.26) / 6.0, 1e-7);
  const double y0 = 0.2126 * 1 + 0.7152 * 2 + 0.0722 * 3, y1 = 0.0;
  EXPECT_NEAR(m.lumaRmse, std::sqrt(((y0 - 1) * (y0 - 1) + 0.25) / 2.0), 1e-6);
  EXPECT_NEAR(m.lumaRatio, (y0 + y1) / 1.5, 1e-6);
  // rmspe: both reference pixels are lit (Y = 1 and 0.5).
  EXPECT_NEAR(m.rmspe, std::sqrt(((y0 - 1) * (y0 - 1) + 1.0) / 2.0), 1e-6);
  EXPECT_EQ(m.pixels, 2u);
}

TEST(Metrics, IdenticalImagesHaveZeroErrorAndUnitRatio) {
  ImageRgb a(3, 2);
  for (size_t i = 0; i < a.Size(); ++i) a.pixels[i] = Vec3(float(i), 0.5f, 2.0f);
  const AccuracyMetrics m = MeasureAccuracy(a, a);
  EXPECT_EQ(m.rmse, 0.0);
  EXPECT_EQ(m.relmse, 0.0);
  EXPECT_EQ(m.lumaRatio, 1.0);
}

TEST(Metrics, MaskRestrictsPixels) {
  ImageRgb est(2, 1), ref(2, 1);
  est.pixels = {Vec3(1), Vec3(5)};
  ref.pixels = {Vec3(1), Vec3(0)};
  const std::vector<uint8_t> mask{1, 0};
  const AccuracyMetrics m = MeasureAccuracy(est, ref, &mask);
  EXPECT_EQ(m.rmse, 0.0);
  EXPECT_EQ(m.pixels, 1u);
  EXPECT_DOUBLE_EQ(MaskFraction(mask), 0.5);
}

TEST(ImageHash, ChangesWithOneBit) {
  ImageRgb a(4, 4);
  const uint64_t h = HashImage(a);
  a.pixels[7].y = -0.0f;  // same value, different bits
  EXPECT_NE(h, HashImage(a));
}

}  // namespace
}  // namespace restir
