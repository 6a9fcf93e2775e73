// The temporal-reuse pass alone on a hand-made frame (sim/estimator/passes/temporal_reuse.h): with a previous frame
// every pixel combines its reservoir with the one it reprojects onto, the previous confidence capped at maxHistory;
// pixels whose reprojection failed, and every pixel without a previous frame, keep their reservoir untouched. A
// sample taken from the previous frame is a frame older.
#include "sim/estimator/passes/temporal_reuse.h"

#include <gtest/gtest.h>

#include <cmath>

#include "hand_made_frame.h"
#include "sim/estimator/passes/initial_sampling.h"

namespace restir {
namespace {

struct Buffers {
  ReservoirBuffer current, previous;
};

// This frame's initial reservoirs (seed 1) and a previous frame's (seed 2) with confidence `previousConfidence`.
Buffers Initial(test::HandMadeFrame& f, float previousConfidence) {
  Buffers b;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(1), b.current, stats);
  InitialSampling(InitialSamplingParams{}, f.View(2), b.previous, stats);
  for (StoredReservoir& r : b.previous) r.confidence = previousConfidence;
  return b;
}

bool SameSample(const StoredReservoir& a, const StoredReservoir& b) {
  return a.lightId == b.lightId && a.position == b.position;
}

TEST(TemporalReuse, CombinesWithTheReprojectedReservoirAndCapsItsConfidence) {
  test::HandMadeFrame f(9, 5);
  f.gbuffer.prevValid[4] = 0;  // reprojection failed here
  Buffers b = Initial(f, 50.0f);
  for (StoredReservoir& r : b.previous) r.history.age = 7, r.history.visibilityAge = 2;
  const ReservoirBuffer before = b.current;
  TemporalParams params;
  params.enabled = true;
  params.maxHistory = 20.0f;
  std::vector<uint8_t> accepted;
  PassStats stats;
  TemporalReuse(params, f.View(1, 1, /*history=*/true), b.previous, b.current, accepted, stats);
  EXPECT_EQ(stats.name, "temporal");
  EXPECT_EQ(stats.rays, 0u);  // basic bias correction traces nothing
  EXPECT_EQ(stats.combinations, f.gbuffer.Size() - 1);
  EXPECT_EQ(stats.crossObjectReuse, 0u);
  size_t fromPrevious = 0;
  for (size_t i = 0; i < b.current.size(); ++i) {
    if (i == 4) {
      EXPECT_EQ(accepted[i], 0);
      EXPECT_TRUE(SameSample(b.current[i], before[i]));
      EXPECT_EQ(b.current[i].confidence, 1.0f);
      continue;
    }
    EXPECT_EQ(accepted[i], 1) << i;
    EXPECT_EQ(b.current[i].confidence, 1.0f + 20.0f) << i;  // c_cur + min(c_prev, maxHistory)
    // The selected sample is one of the two inputs.
    EXPECT_TRUE(SameSample(b.current[i], before[i]) || SameSample(b.current[i], b.previous[i])) << i;
    fromPrevious += SameSample(b.current[i], b.previous[i]);
    // Initial samples are distinct points, so the age says which input won: 0 for this frame's, 7 + 1 for the
    // previous frame's.
    const bool previousWon = SameSample(b.current[i], b.previous[i]);
    EXPECT_EQ(b.current[i].history.age, previousWon ? 8u : 0u) << i;
    EXPECT_EQ(b.current[i].history.visibilityAge, previousWon ? 3u : 0u) << i;
    EXPECT_EQ(b.current[i].history.distanceX, 0) << i;  // every pixel reprojects onto itself
  }
  // With 20 : 1 confidence, nearly every pixel keeps the previous sample.
  EXPECT_GT(fromPrevious, (b.current.size() - 1) * 3 / 4);
}

TEST(TemporalReuse, WithoutAPreviousFrameChangesNothing) {
  test::HandMadeFrame f(6, 4);
  Buffers b = Initial(f, 5.0f);
  const ReservoirBuffer before = b.current;
  TemporalParams params;
  params.enabled = true;
  std::vector<uint8_t> accepted;
  PassStats stats;
  TemporalReuse(params, f.View(1, 0, /*history=*/false), b.previous, b.current, accepted, stats);
  EXPECT_EQ(stats.combinations, 0u);
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(accepted[i], 0);
    EXPECT_TRUE(SameSample(b.current[i], before[i]));
    EXPECT_EQ(b.current[i].W, before[i].W);
  }
}

// Pairwise MIS with ray-traced bias correction, the sample checks off: the setting of the visibility tests below.
TemporalParams RayTracedPairwise() {
  TemporalParams params;
  params.enabled = true;
  params.mis = MisFamily::kPairwise;
  params.bias = BiasCorrection::kRayTraced;
  params.sampleChecks = false;
  return params;
}

// Ray-traced bias correction traces the targets' visibility, in each input's own frame.
TEST(TemporalReuse, RayTracedBiasCorrectionTracesVisibility) {
  test::HandMadeFrame f(8, 4, /*occluder=*/true);
  Buffers b = Initial(f, 3.0f);
  TemporalParams params = RayTracedPairwise();
  std::vector<uint8_t> accepted;
  PassStats stats;
  TemporalReuse(params, f.View(1, 1, true), b.previous, b.current, accepted, stats);
  EXPECT_GT(stats.rays, f.gbuffer.Size());
  EXPECT_GT(stats.targets, 2 * f.gbuffer.Size() - 1);
  for (size_t i = 0; i < b.current.size(); ++i)
    if (f.gbuffer.posX[i] < -0.25f) {
      EXPECT_FALSE(b.current[i].HasSample()) << "shadowed pixel " << i;
    }
}

// RTXDI's visibility shortcut: with ray-traced bias correction the previous sample counts as visible at the
// previous surface, without a ray. Where nothing moved (this frame's previous surface is the same floor under the
// same occluder) that is what the ray would have found for every sample the combination can select (an occluded
// previous sample has a zero canonical target either way), so every reservoir comes out the same, with fewer rays.
TEST(TemporalReuse, VisibilityShortcutSavesRaysAndChangesNothingWhereNothingMoved) {
  test::HandMadeFrame f(16, 4, /*occluder=*/true);
  uint64_t rays[2];
  ReservoirBuffer out[2];
  for (int shortcut = 0; shortcut < 2; ++shortcut) {
    Buffers b = Initial(f, 3.0f);
    TemporalParams params = RayTracedPairwise();
    params.visibilityShortcut = shortcut == 1;
    std::vector<uint8_t> accepted;
    PassStats stats;
    TemporalReuse(params, f.View(1, 1, true), b.previous, b.current, accepted, stats);
    rays[shortcut] = stats.rays;
    out[shortcut] = b.current;
  }
  EXPECT_LT(rays[1], rays[0]);
  for (size_t i = 0; i < out[0].size(); ++i) {
    EXPECT_TRUE(SameSample(out[0][i], out[1][i])) << i;
    EXPECT_EQ(out[0][i].W, out[1][i].W) << i;
  }
}

// RTXDI's fused spatiotemporal resampling: the temporal combination also takes previous-frame neighbours of the
// reprojected pixel, so a pixel's confidence is its own, the previous pixel's and its accepted neighbours', and its
// sample comes from one of them: never from farther than the radius, never from another surface.
TEST(TemporalReuse, FusedSpatiotemporalCombinesPreviousFrameNeighbours) {
  test::HandMadeFrame f(24, 12);
  // The right half faces another way in both frames: no pixel may take a sample across.
  for (GBuffer* g : {&f.gbuffer, &f.previous})
    for (size_t i = 0; i < g->Size(); ++i)
      if (static_cast<int>(i % 24) >= 12) g->ngX[i] = 1, g->ngY[i] = 0, g->nsX[i] = 1, g->nsY[i] = 0;
  Buffers b = Initial(f, 2.0f);
  const ReservoirBuffer before = b.current, previous = b.previous;
  TemporalParams params;
  params.enabled = true;
  params.mis = MisFamily::kPairwise;
  params.sampleChecks = false;
  params.fusedNeighbours = 5;
  params.fusedRadius = 3.0f;
  std::vector<uint8_t> accepted;
  PassStats stats;
  TemporalReuse(params, f.View(1, 1, true), b.previous, b.current, accepted, stats);
  double neighbours = 0.0;
  for (size_t i = 0; i < b.current.size(); ++i) {
    const int x = static_cast<int>(i % 24), y = static_cast<int>(i / 24);
    const float extra = b.current[i].confidence - 1.0f - 2.0f;  // beyond its own and the previous pixel's
    EXPECT_GE(extra, 0.0f) << i;
    EXPECT_LE(extra, 2.0f * 5) << i;
    EXPECT_EQ(std::fmod(extra, 2.0f), 0.0f) << i;  // whole neighbours of confidence 2
    neighbours += extra / 2.0f;
    if (!b.current[i].HasSample() || SameSample(b.current[i], before[i])) continue;
    int source = -1;
    for (size_t j = 0; j < previous.size(); ++j)
      if (SameSample(previous[j], b.current[i])) source = static_cast<int>(j);
    ASSERT_GE(source, 0) << i;
    EXPECT_EQ(source % 24 >= 12, x >= 12) << i << " took its sample across the crease, from " << source;
    EXPECT_LE(std::hypot(source % 24 - x, source / 24 - y), params.fusedRadius + 0.71) << i;
  }
  EXPECT_GT(neighbours / b.current.size(), 2.0);  // most of the 5 draws land on the same surface
}

}  // namespace
}  // namespace restir
