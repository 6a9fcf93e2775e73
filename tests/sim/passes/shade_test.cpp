// The shading pass alone on a hand-made frame (sim/passes/shade.h): with a final ray a pixel is f(Y) W where the
// ray is clear and 0 where it is blocked, one ray per sample that can contribute; with carried visibility it is
// f(Y) V W and no ray is traced; a non-finite pixel is written as 0 and counted.
#include "sim/passes/shade.h"

#include <gtest/gtest.h>

#include "core/shading.h"
#include "hand_made_frame.h"
#include "sim/passes/initial_sampling.h"
#include "sim/shading_point.h"

namespace restir {
namespace {

Vec3 Unshadowed(const test::HandMadeFrame& f, size_t i, const StoredReservoir& r) {
  LightSample y;
  y.lightId = r.lightId;
  y.position = r.position;
  y.normal = r.normal;
  y.radiance = f.scene->LightTriangles()[r.lightId].radiance;
  return UnshadowedContribution(
      ShadingPointAt(f.gbuffer, i, f.state.camera.position, {Bsdf{BsdfType::kDiffuse, Vec3(0.5f), 0.0f}}), y);
}

TEST(Shade, FinalRayKeepsClearSamplesAndZeroesBlockedOnes) {
  test::HandMadeFrame f(12, 4, /*occluder=*/true);
  ReservoirBuffer reservoirs;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(2), reservoirs, stats);
  ImageRgb image;
  Shade(ShadeParams{}, f.View(2), reservoirs, image, stats);
  EXPECT_EQ(stats.name, "shade");
  EXPECT_EQ(stats.rays, f.gbuffer.Size());
  EXPECT_EQ(stats.guarded, 0u);
  for (size_t i = 0; i < image.Size(); ++i) {
    const float x = f.gbuffer.posX[i];
    if (x < -0.25f) {
      EXPECT_EQ(image.pixels[i], Vec3(0.0f)) << x;
    }
    if (x > 0.25f) {
      // The target kernel's f, to the bit, times W.
      EXPECT_EQ(image.pixels[i], Unshadowed(f, i, reservoirs[i]) * reservoirs[i].W) << x;
      EXPECT_GT(image.pixels[i].x, 0.0f);
    }
  }
}

TEST(Shade, CarriedVisibilityScalesWithoutARay) {
  test::HandMadeFrame f(6, 3, /*occluder=*/true);
  ReservoirBuffer reservoirs;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(4), reservoirs, stats);
  for (StoredReservoir& r : reservoirs) r.visibility = 0.5f;
  ImageRgb image;
  ShadeParams params;
  params.visibility = VisibilityReuse::kWeighted;
  Shade(params, f.View(4), reservoirs, image, stats);
  EXPECT_EQ(stats.rays, 0u);
  for (size_t i = 0; i < image.Size(); ++i)
    EXPECT_EQ(image.pixels[i], Unshadowed(f, i, reservoirs[i]) * 0.5f * reservoirs[i].W) << i;
}

TEST(Shade, NonFinitePixelIsWrittenAsZeroAndCounted) {
  test::HandMadeFrame f(4, 2);
  ReservoirBuffer reservoirs;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(6), reservoirs, stats);
  reservoirs[3].W = std::numeric_limits<float>::infinity();
  ImageRgb image;
  Shade(ShadeParams{}, f.View(6), reservoirs, image, stats);
  EXPECT_EQ(stats.guarded, 1u);
  EXPECT_EQ(image.pixels[3], Vec3(0.0f));
  EXPECT_GT(image.pixels[2].x, 0.0f);
}

}  // namespace
}  // namespace restir
