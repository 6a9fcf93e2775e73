// The shading pass alone on a hand-made frame (sim/estimator/passes/shade.h): with a final ray a pixel is f(Y) W
// where the ray is clear and 0 where it is blocked, one ray per sample that can contribute; with carried visibility
// it is f(Y) V W and no ray is traced; a non-finite pixel is written as 0 and counted; RTXDI's final-visibility reuse
// stores and reuses within its limits.
#include "sim/estimator/passes/shade.h"

#include <gtest/gtest.h>

#include "core/shading.h"
#include "hand_made_frame.h"
#include "sim/estimator/passes/initial_sampling.h"
#include "sim/scene/shading_point.h"

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

// RTXDI's final-visibility reuse: a traced visibility is stored (visibility age and distance reset); a stored one
// stands in for the ray only when 0 < age <= maxAge and the distance moved is under maxDistance (RTXDI's tests,
// limits included: age 4 and 16 px by default).
TEST(Shade, ReusedFinalVisibilityReplacesTheRayOnlyWithinItsAgeAndDistance) {
  test::HandMadeFrame f(12, 4, /*occluder=*/true);
  ReservoirBuffer reservoirs;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(2), reservoirs, stats);
  ShadeParams params;
  params.reuseFinalVisibility = true;
  ImageRgb traced;
  // Fresh samples (visibility age 0): every one is traced, and its visibility is stored.
  for (StoredReservoir& r : reservoirs) r.history.distanceX = 5;
  Shade(params, f.View(2), reservoirs, traced, stats);
  EXPECT_EQ(stats.rays, f.gbuffer.Size());
  for (size_t i = 0; i < reservoirs.size(); ++i) {
    EXPECT_EQ(reservoirs[i].visibility, traced.pixels[i].x > 0.0f ? 1.0f : 0.0f) << i;
    EXPECT_EQ(reservoirs[i].history.visibilityAge, 0) << i;
    EXPECT_EQ(reservoirs[i].history.distanceX, 0) << i;
  }
  // Stored visibility inverted, so a pixel shows which one it used; ages and distances on both sides of the limits.
  struct Case {
    uint8_t age;
    int8_t dx, dy;
    bool reused;
  };
  const Case cases[] = {{1, 0, 0, true},   {4, 0, 0, true},   {5, 0, 0, false}, {0, 0, 0, false},
                        {2, 11, 11, true}, {2, 12, 12, false}, {3, -15, 0, true}, {3, 0, -16, false}};
  for (size_t i = 0; i < reservoirs.size(); ++i) {
    const Case& c = cases[i % 8];
    reservoirs[i].visibility = 1.0f - reservoirs[i].visibility;
    reservoirs[i].history.visibilityAge = c.age;
    reservoirs[i].history.distanceX = c.dx;
    reservoirs[i].history.distanceY = c.dy;
  }
  const ReservoirBuffer before = reservoirs;
  ImageRgb image;
  Shade(params, f.View(2), reservoirs, image, stats);
  size_t expectedRays = 0;
  for (size_t i = 0; i < image.Size(); ++i) {
    const Case& c = cases[i % 8];
    expectedRays += !c.reused;
    const Vec3 withStored = Unshadowed(f, i, before[i]) * before[i].visibility * before[i].W;
    if (c.reused) {
      EXPECT_EQ(image.pixels[i], withStored) << i;
      EXPECT_EQ(reservoirs[i].history.visibilityAge, c.age) << i;  // nothing stored
    } else {
      EXPECT_EQ(image.pixels[i], traced.pixels[i]) << i;
      EXPECT_EQ(reservoirs[i].history.visibilityAge, 0) << i;
    }
  }
  EXPECT_EQ(stats.rays, expectedRays);
  // Off, nothing is read or written.
  ReservoirBuffer untouched = before;
  Shade(ShadeParams{}, f.View(2), untouched, image, stats);
  EXPECT_EQ(stats.rays, f.gbuffer.Size());
  for (size_t i = 0; i < image.Size(); ++i) {
    EXPECT_EQ(image.pixels[i], traced.pixels[i]) << i;
    EXPECT_EQ(untouched[i].visibility, before[i].visibility);
  }
}

// RTXDI's discardInvisibleSamples: the samples the final ray finds occluded leave the kept reservoirs (W = 0,
// confidence 0), the visible ones stay as they were, and the image is the one shading without it gives.
TEST(Shade, DiscardingInvisibleSamplesEmptiesOnlyTheOccludedOnes) {
  test::HandMadeFrame f(12, 4, /*occluder=*/true);
  ReservoirBuffer reservoirs;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(3), reservoirs, stats);
  ReservoirBuffer kept = reservoirs;
  ImageRgb plain, discarding;
  Shade(ShadeParams{}, f.View(3), reservoirs, plain, stats);
  ShadeParams params;
  params.discardInvisibleSamples = true;
  Shade(params, f.View(3), kept, discarding, stats);
  size_t dropped = 0;
  for (size_t i = 0; i < kept.size(); ++i) {
    EXPECT_EQ(discarding.pixels[i], plain.pixels[i]) << i;
    const bool occluded = reservoirs[i].HasSample() && plain.pixels[i] == Vec3(0.0f);
    if (occluded) {
      EXPECT_EQ(kept[i].W, 0.0f) << i;
      EXPECT_EQ(kept[i].confidence, 0.0f) << i;
      ++dropped;
    } else {
      EXPECT_EQ(kept[i].W, reservoirs[i].W) << i;
      EXPECT_EQ(kept[i].confidence, reservoirs[i].confidence) << i;
    }
  }
  EXPECT_GT(dropped, kept.size() / 5);  // the pixels under the occluder
}

}  // namespace
}  // namespace restir
