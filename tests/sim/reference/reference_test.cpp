#include "sim/reference/reference.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/polygon_irradiance.h"
#include "tests/sim/scene_fixtures.h"
#include "sim/estimator/pipeline.h"
#include "sim/scene/shading_point.h"
#include "sim/estimator/presets.h"
#include "stats.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace reference_test {

// Closed form for the floor fixture: Lambertian outgoing radiance albedo/π · E(x), E from Lambert's polygon
// formula.
double ExactRadiance(const Sequence& seq, const Vec3& x, float albedo) {
  const Light& l = seq.lights.front();
  const std::vector<Vec3> quad{l.vertices[0], l.vertices[1], l.vertices[2], l.vertices[5]};
  return albedo / M_PI * PolygonIrradiance(x, Vec3(0, 1, 0), quad, l.radiance.x);
}

struct Rendered {
  Sequence seq;
  FrameState state;
  std::unique_ptr<EmbreeScene> scene;
  GBuffer gbuffer;
};

Rendered MakeFloorScene(int w, int h) {
  Rendered r;
  r.seq = test::FloorUnderQuadLight(w, h, 1.0f, 0.6f);
  r.state = test::StaticState(r.seq);
  r.scene = std::make_unique<EmbreeScene>(r.seq);
  r.scene->Update(r.state);
  TracePrimary(*r.scene, r.state.camera, r.gbuffer);
  return r;
}

// The reference matches Lambert's formula within its own standard error. The standard error comes from 16
// replicates, so z = (ref - exact) / stderr is Student-t with 15 dof and z² is F(1, 15): mean 15/13, variance
// 3.389. Test: the mean of z² over k independent pixels lies within 15/13 ± 3.72 sqrt(3.389 / k) (normal
// approximation of the mean; false-failure rate 2e-4; fixed seed, so deterministic). Above the band means bias
// (or an underestimated error); below it, an overestimated error.
TEST(Reference, MatchesLambertPolygonFormulaWithinItsStandardError) {
  Rendered r = MakeFloorScene(24, 16);
  ReferenceParams params;
  params.samplesPerPixel = 2048;
  // The sampled estimate: with the difference estimator this unoccluded floor is exact, standard error 0
  // (tests/sim/reference/closed_form_test.cpp holds that).
  params.differenceShadows = false;
  const ReferenceImage ref = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  double sumZ2 = 0;
  int k = 0;
  for (size_t i = 0; i < r.gbuffer.Size(); ++i) {
    if (!r.gbuffer.IsSurface(i)) continue;
    const double exact = ExactRadiance(r.seq, r.gbuffer.Position(i), 0.6f);
    const double se = ref.standardError.pixels[i].x;
    ASSERT_GT(se, 0.0);
    const double z = (ref.mean.pixels[i].x - exact) / se;
    sumZ2 += z * z;
    ++k;
  }
  ASSERT_GT(k, 300);
  const double band = test::NormalQuantileUpper(1e-4) * std::sqrt(3.389 / k);
  std::printf("closed-form check: %d pixels, mean z^2 = %.3f (expected 1.154 +- %.3f), mean rel. stderr %.4f\n", k,
              sumZ2 / k, band, MeanRelativeStandardError(ref));
  EXPECT_LT(sumZ2 / k, 15.0 / 13.0 + band) << "pixels " << k;
  EXPECT_GT(sumZ2 / k, 15.0 / 13.0 - band) << "pixels " << k;
  // And the reference is far from trivially loose: its mean relative error is a few percent at most.
  EXPECT_LT(MeanRelativeStandardError(ref), 0.05);
}

// The `ris` preset's mean over 96 independent seeds matches Lambert's formula: per pixel the seed mean's
// z-score against the closed form (standard error from the seeds' spread); sum of z² over pixels tested against
// chi-square with (pixels) dof, false-failure rate 1e-4.
TEST(Reference, RisMeanOverSeedsMatchesLambertChiSquare) {
  Rendered r = MakeFloorScene(16, 12);
  const std::vector<Bsdf> bsdfs = MaterialBsdfs(r.seq);
  const LightSampler lights(r.scene->LightTriangles(), LightSelection::kPower);
  Pipeline pipeline(FindPreset("ris")->settings);
  std::vector<test::RunningStats> stats(r.gbuffer.Size());
  for (uint32_t seed = 0; seed < 96; ++seed) {
    FrameInputs in;
    in.state = &r.state;
    in.scene = r.scene.get();
    in.gbuffer = &r.gbuffer;
    in.lights = &lights;
    in.materials = &bsdfs;
    in.seed = 1000 + seed;
    const FrameResult fr = pipeline.RenderFrame(in);
    for (size_t i = 0; i < stats.size(); ++i) stats[i].Add(fr.image.pixels[i].x);
  }
  double chi2 = 0;
  int k = 0;
  for (size_t i = 0; i < stats.size(); ++i) {
    if (!r.gbuffer.IsSurface(i)) continue;
    const double exact = ExactRadiance(r.seq, r.gbuffer.Position(i), 0.6f);
    if (stats[i].StdError() == 0) {
      EXPECT_NEAR(stats[i].mean, exact, 1e-5 * exact);
      continue;
    }
    const double z = (stats[i].mean - exact) / stats[i].StdError();
    chi2 += z * z;
    ++k;
  }
  ASSERT_GT(k, 100);
  // Student-t z² has heavier tails than χ²(1) with 95 dof; the mean of t²(95) is 95/93, so scale the statistic.
  std::printf("ris over 96 seeds: %d pixels, chi2 %.1f (critical %.1f)\n", k, chi2 * 93.0 / 95.0,
              test::ChiSquareCritical(k, 1e-4));
  EXPECT_LT(chi2 * 93.0 / 95.0, test::ChiSquareCritical(k, 1e-4)) << "pixels " << k;
}

// Several lights of very different power, one of them crossing the receiver's horizon: the reference's per-pixel
// light selection must still converge to the sum of Lambert's formula over the parts above the horizon. Same
// statistic and band as above (false-failure rate 2e-4).
TEST(Reference, ManyLightsMatchLambertSumWithinItsStandardError) {
  Sequence seq = test::FloorUnderQuadLight(24, 16, 1.0f, 0.5f);
  // Placed so that no light occludes another as seen from the visible floor (emitters are geometry too, and
  // the closed form knows no occlusion).
  test::AddQuadLight(seq, "dim_far", Vec3(-1.5f, 0.6f, -1.5f), Vec3(0.3f, 0, 0), Vec3(0, 0, 0.3f), Vec3(0.5f));
  test::AddQuadLight(seq, "tiny_bright", Vec3(1.2f, 0.4f, -1.6f), Vec3(0.02f, 0, 0), Vec3(0, 0, 0.02f),
                     Vec3(400.0f));
  // A vertical panel facing +x that reaches below the floor plane (y from -0.3 to 0.5).
  test::AddQuadLight(seq, "horizon", Vec3(-1.9f, 0.1f, 0.0f), Vec3(0, 0.4f, 0), Vec3(0, 0, 0.3f), Vec3(3.0f));
  const FrameState state = test::StaticState(seq);
  EmbreeScene scene(seq);
  scene.Update(state);
  GBuffer g;
  TracePrimary(scene, state.camera, g);
  ReferenceParams params;
  params.samplesPerPixel = 1024;
  const ReferenceImage ref = RenderReference(seq, state, scene, g, params);
  double sumZ2 = 0;
  int k = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    const Vec3 x = g.Position(i);
    double exact = 0;
    for (const Light& l : seq.lights) {
      const std::vector<Vec3> quad{l.vertices[0], l.vertices[1], l.vertices[2], l.vertices[5]};
      // One-sided emitters: only lights whose front faces x contribute.
      const Vec3 n = glm::normalize(glm::cross(l.vertices[1] - l.vertices[0], l.vertices[2] - l.vertices[0]));
      if (glm::dot(n, x - l.vertices[0]) <= 0) continue;
      const auto clipped = ClipPolygonToHemisphere(x, Vec3(0, 1, 0), quad);
      if (clipped.size() >= 3) exact += 0.5 / M_PI * PolygonIrradiance(x, Vec3(0, 1, 0), clipped, l.radiance.x);
    }
    const double se = ref.standardError.pixels[i].x;
    ASSERT_GT(se, 0.0);
    const double z = (ref.mean.pixels[i].x - exact) / se;
    sumZ2 += z * z;
    ++k;
  }
  ASSERT_GT(k, 300);
  const double band = test::NormalQuantileUpper(1e-4) * std::sqrt(3.389 / k);
  std::printf("many-light check: %d pixels, mean z^2 = %.3f (expected 1.154 +- %.3f), mean rel. stderr %.4f\n", k,
              sumZ2 / k, band, MeanRelativeStandardError(ref));
  EXPECT_LT(sumZ2 / k, 15.0 / 13.0 + band);
  EXPECT_GT(sumZ2 / k, 15.0 / 13.0 - band);
}

TEST(Reference, CacheRoundTripsBitExactly) {
  Rendered r = MakeFloorScene(12, 8);
  ReferenceParams params;
  params.samplesPerPixel = 16;
  params.cacheDir = ::testing::TempDir() + "/restir-ref-cache-test";
  std::filesystem::remove_all(params.cacheDir);
  const ReferenceImage a = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  const ReferenceImage b = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  EXPECT_FALSE(a.fromCache);
  EXPECT_TRUE(b.fromCache);
  EXPECT_EQ(HashImage(a.mean), HashImage(b.mean));
  EXPECT_EQ(HashImage(a.standardError), HashImage(b.standardError));
  // A different sample count, error target, camera or light state is a different key; the frame index alone is
  // not, and neither is the budget when an error target replaces it.
  auto key = [&](const FrameState& s, int spp, double error = 0.0) {
    ReferenceParams p;
    p.samplesPerPixel = spp;
    p.targetRelativeError = error;
    return ReferenceCacheKey(r.seq, s, p);
  };
  EXPECT_NE(key(r.state, 16), key(r.state, 17));
  EXPECT_NE(key(r.state, 16), key(r.state, 16, 0.01));
  EXPECT_NE(key(r.state, 16, 0.01), key(r.state, 16, 0.02));
  EXPECT_EQ(key(r.state, 16, 0.01), key(r.state, 64, 0.01));
  FrameState moved = r.state;
  moved.camera.position.x += 1e-3f;
  EXPECT_NE(key(r.state, 16), key(moved, 16));
  FrameState dark = r.state;
  dark.lightOn[0] = 0;
  EXPECT_NE(key(r.state, 16), key(dark, 16));
  FrameState later = r.state;
  later.frame = 7;
  EXPECT_EQ(key(r.state, 16), key(later, 16));
  // Each switch that changes what the reference computes is in the key.
  ReferenceParams unspread;
  unspread.samplesPerPixel = 16;
  unspread.spreadRelativeVariance = false;
  EXPECT_NE(key(r.state, 16), ReferenceCacheKey(r.seq, r.state, unspread));
}

// An error target the frame cannot afford stops at the cap: the frame is then the fixed-budget frame at the cap, to
// the bit, its scale (the cap over what the target would take) below 1 and its measured noise above the target; a
// cap the target does not reach changes nothing, to the bit. A cached frame reports the same allocation as the
// rendered one. The cap is part of an error target's cache key, not a budget's.
TEST(Reference, ErrorTargetStopsAtTheFramesSampleCapAndSaysSo) {
  Rendered r = MakeFloorScene(24, 16);
  ReferenceParams params;
  params.targetRelativeError = 0.002;
  params.differenceShadows = false;  // with it this unoccluded floor is exact: any target is reached at once
  for (const int cap : {64, 256, 1000}) {
    params.maxMeanSamplesPerPixel = cap;
    const ReferenceImage capped = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
    ReferenceParams budget;
    budget.samplesPerPixel = cap;
    budget.differenceShadows = false;
    const ReferenceImage fixed = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, budget);
    EXPECT_LT(capped.allocation.scale, 1.0) << cap;
    EXPECT_EQ(HashImage(capped.mean), HashImage(fixed.mean)) << cap;
    EXPECT_EQ(capped.pixelSamples, fixed.pixelSamples) << cap;
    EXPECT_EQ(capped.allocation.meanSamplesPerPixel, fixed.allocation.meanSamplesPerPixel) << cap;
    EXPECT_EQ(fixed.allocation.scale, 1.0);
    EXPECT_GT(MeanRelativeStandardError(capped), params.targetRelativeError) << cap;
    double sum = 0.0;
    size_t n = 0;
    for (uint32_t s : capped.pixelSamples)
      if (s > 0) sum += s, ++n;
    EXPECT_EQ(capped.allocation.meanSamplesPerPixel, sum / double(n));
  }
  params.targetRelativeError = 0.05;
  params.maxMeanSamplesPerPixel = 0;
  const ReferenceImage free = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  params.maxMeanSamplesPerPixel = 1 << 20;
  params.cacheDir = ::testing::TempDir() + "/restir-ref-cap-test";
  std::filesystem::remove_all(params.cacheDir);
  const ReferenceImage roomy = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  EXPECT_EQ(roomy.allocation.scale, 1.0);
  EXPECT_EQ(HashImage(roomy.mean), HashImage(free.mean));
  EXPECT_EQ(roomy.pixelSamples, free.pixelSamples);
  params.targetRelativeError = 0.002;
  params.maxMeanSamplesPerPixel = 64;
  const ReferenceImage rendered = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  const ReferenceImage cached = RenderReference(r.seq, r.state, *r.scene, r.gbuffer, params);
  ASSERT_TRUE(cached.fromCache);
  EXPECT_EQ(cached.allocation.scale, rendered.allocation.scale);
  EXPECT_EQ(cached.allocation.meanSamplesPerPixel, rendered.allocation.meanSamplesPerPixel);
  auto key = [&](int spp, double error, int cap) {
    ReferenceParams p;
    p.samplesPerPixel = spp;
    p.targetRelativeError = error;
    p.maxMeanSamplesPerPixel = cap;
    return ReferenceCacheKey(r.seq, r.state, p);
  };
  EXPECT_NE(key(16, 0.01, 64), key(16, 0.01, 65));
  EXPECT_NE(key(16, 0.01, 64), key(16, 0.01, 0));
  EXPECT_EQ(key(16, 0.0, 64), key(16, 0.0, 0));
}

// The nearest-rank quantile that MeasureReferenceConvergence and the oracle bench quote, against NumPy's
// np.percentile(np.arange(n), 100 q, method='inverted_cdf') (the nearest-rank definition), computed outside the
// project for these counts.
TEST(NearestRankIndex, MatchesNumpysInvertedCdfPercentile) {
  struct Case {
    size_t count;
    size_t p99, p50;
  };
  for (const Case& c : {Case{1, 0, 0}, Case{2, 1, 0}, Case{100, 98, 49}, Case{101, 99, 50}, Case{200, 197, 99},
                        Case{1000, 989, 499}, Case{166310, 164646, 83154}}) {
    EXPECT_EQ(NearestRankIndex(c.count, 0.99), c.p99) << c.count;
    EXPECT_EQ(NearestRankIndex(c.count, 0.5), c.p50) << c.count;
    EXPECT_EQ(NearestRankIndex(c.count, 0.0), 0u) << c.count;
    EXPECT_EQ(NearestRankIndex(c.count, 1.0), c.count - 1) << c.count;
  }
}

}  // namespace reference_test
}  // namespace restir
