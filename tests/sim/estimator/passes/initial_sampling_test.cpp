// The initial-sampling pass alone on a hand-made frame (sim/estimator/passes/initial_sampling.h): a reservoir on the
// light for every surface pixel with its exact target and confidence, empty elsewhere; visibility zeroes exactly the
// occluded samples and counts its rays; and the estimate f(Y) W is unbiased against Lambert's closed form.
#include "sim/estimator/passes/initial_sampling.h"

#include <gtest/gtest.h>

#include "core/polygon_irradiance.h"
#include "core/shading.h"
#include "hand_made_frame.h"
#include "sim/scene/shading_point.h"
#include "stats.h"

namespace restir {
namespace {

ShadingPoint FloorPoint(const test::HandMadeFrame& f, size_t i) {
  return ShadingPointAt(f.gbuffer, i, f.state.camera.position, {Bsdf{BsdfType::kDiffuse, Vec3(0.5f), 0.0f}});
}

LightSample SampleOf(const StoredReservoir& r, const std::vector<LightTriangle>& lights) {
  LightSample y;
  y.lightId = r.lightId;
  y.position = r.position;
  y.normal = r.normal;
  y.radiance = lights[r.lightId].radiance;
  return y;
}

TEST(InitialSampling, EverySurfacePixelGetsAReservoirOnTheLightWithItsExactTarget) {
  test::HandMadeFrame f(8, 6);
  f.gbuffer.objectId[5] = -1;  // one pixel sees no surface
  f.gbuffer.materialId[5] = -1;
  f.gbuffer.bsdfId[5] = -1;
  ReservoirBuffer out;
  PassStats stats;
  InitialSamplingParams params;
  InitialSampling(params, f.View(), out, stats);
  ASSERT_EQ(out.size(), f.gbuffer.Size());
  EXPECT_EQ(stats.name, "initial");
  EXPECT_EQ(stats.risPixels, f.gbuffer.Size() - 1);
  EXPECT_EQ(stats.rays, 0u);
  EXPECT_FALSE(out[5].HasSample());
  const std::vector<LightTriangle>& lights = f.scene->LightTriangles();
  for (size_t i = 0; i < out.size(); ++i) {
    if (i == 5) continue;
    const StoredReservoir& r = out[i];
    ASSERT_TRUE(r.HasSample()) << i;
    ASSERT_LT(r.lightId, lights.size());
    EXPECT_NEAR(r.position.y, 1.0f, 1e-6f);
    EXPECT_LE(std::fabs(r.position.x), 0.25f + 1e-6f);
    EXPECT_LE(std::fabs(r.position.z), 0.25f + 1e-6f);
    // The stored target is p̂ of the stored sample at this pixel, to the bit (core/shading.h).
    EXPECT_EQ(r.targetPdf, TargetFunction(UnshadowedContribution(FloorPoint(f, i), SampleOf(r, lights)))) << i;
    EXPECT_EQ(r.confidence, 1.0f);
    EXPECT_EQ(r.visibility, 1.0f);
  }
  params.countCandidates = true;
  InitialSampling(params, f.View(), out, stats);
  EXPECT_EQ(out[0].confidence, static_cast<float>(params.candidates));
}

TEST(InitialSampling, VisibilityZeroesExactlyTheOccludedSamples) {
  test::HandMadeFrame f(20, 4, /*occluder=*/true);
  ReservoirBuffer out;
  PassStats stats;
  InitialSamplingParams params;
  params.visibility = true;
  InitialSampling(params, f.View(), out, stats);
  EXPECT_EQ(stats.rays, f.gbuffer.Size());  // one per sample: every pixel found one
  int shadowed = 0, lit = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    const float x = f.gbuffer.posX[i];
    // The sheet (x < 0, 0.5 m up) hides the whole light from x < -0.25 and none of it from x > 0.25.
    if (x < -0.25f) {
      EXPECT_FALSE(out[i].HasSample()) << x;
      EXPECT_EQ(out[i].visibility, 0.0f);
      ++shadowed;
    } else if (x > 0.25f) {
      EXPECT_TRUE(out[i].HasSample()) << x;
      EXPECT_EQ(out[i].visibility, 1.0f);
      ++lit;
    }
  }
  EXPECT_EQ(shadowed, 20);  // 5 columns of 4 on either side
  EXPECT_EQ(lit, 20);
}

// f(Y) W over 4000 seeds at one pixel: a z-test of its mean against Lambert's formula (false-failure rate 1e-6,
// two-sided; 4000 samples make the mean normal).
TEST(InitialSampling, EstimateIsUnbiasedAgainstLambert) {
  test::HandMadeFrame f(5, 3);
  const size_t pixel = 7;
  const Vec3 x = f.gbuffer.Position(pixel);
  const Light& light = f.sequence.lights[0];
  const double exact = 0.5 / M_PI * PolygonIrradiance(x, Vec3(0, 1, 0),
                                                      {light.vertices[0], light.vertices[1], light.vertices[2],
                                                       light.vertices[5]},
                                                      light.radiance.x);
  test::RunningStats s;
  ReservoirBuffer out;
  PassStats stats;
  for (uint32_t seed = 0; seed < 4000; ++seed) {
    InitialSampling(InitialSamplingParams{}, f.View(seed), out, stats);
    const StoredReservoir& r = out[pixel];
    s.Add(UnshadowedContribution(FloorPoint(f, pixel), SampleOf(r, f.scene->LightTriangles())).x * r.W);
  }
  EXPECT_NEAR(s.mean, exact, test::NormalQuantileUpper(0.5e-6) * s.StdError()) << "relative " << s.mean / exact - 1;
}

}  // namespace
}  // namespace restir
