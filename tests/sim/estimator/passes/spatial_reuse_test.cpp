// The k-neighbour spatial pass alone on a hand-made frame (sim/estimator/passes/spatial_reuse.h): each pixel's output
// confidence is its own plus that of the similar neighbours it combined, and its sample comes from itself or one
// of them: never from a pixel whose surface differs (another normal), never from outside the radius; where
// temporal reuse failed, more neighbours are drawn. A reused sample keeps its age.
#include "sim/estimator/passes/spatial_reuse.h"

#include <gtest/gtest.h>

#include "hand_made_frame.h"
#include "sim/estimator/passes/initial_sampling.h"

namespace restir {
namespace {

TEST(SpatialReuse, CombinesOnlySimilarNeighboursWithinTheRadius) {
  test::HandMadeFrame f(24, 12);
  // The right half faces another way: no pixel of one half may reuse the other's.
  for (size_t i = 0; i < f.gbuffer.Size(); ++i)
    if (static_cast<int>(i % 24) >= 12)
      f.gbuffer.ngX[i] = 1, f.gbuffer.ngY[i] = 0, f.gbuffer.nsX[i] = 1, f.gbuffer.nsY[i] = 0;
  ReservoirBuffer reservoirs, spare;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(3), reservoirs, stats);
  for (size_t i = 0; i < reservoirs.size(); ++i) reservoirs[i].history.age = static_cast<uint8_t>(i % 200);
  const ReservoirBuffer input = reservoirs;
  SpatialParams params;
  params.enabled = true;
  params.mis = MisFamily::kUniform;
  params.neighbours = 5;
  params.radius = 3.0f;
  SpatialReuse(params, f.View(3), {}, reservoirs, spare, stats);
  EXPECT_EQ(stats.name, "spatial");
  EXPECT_EQ(reservoirs.size(), input.size());
  int combined = 0;
  for (size_t i = 0; i < reservoirs.size(); ++i) {
    const int x = static_cast<int>(i % 24), y = static_cast<int>(i / 24);
    const float c = reservoirs[i].confidence;
    EXPECT_GE(c, 1.0f);
    EXPECT_LE(c, 1.0f + params.neighbours);
    combined += c > 1.0f;
    if (!reservoirs[i].HasSample()) continue;
    // Where did the sample come from? Input samples are distinct points on the light.
    int source = -1;
    for (size_t j = 0; j < input.size(); ++j)
      if (input[j].position == reservoirs[i].position && input[j].lightId == reservoirs[i].lightId) source = int(j);
    ASSERT_GE(source, 0) << i;
    EXPECT_EQ(reservoirs[i].history.age, input[source].history.age)
        << "a reused sample keeps the age it had at pixel " << source;
    // and records the move from its source pixel.
    EXPECT_EQ(reservoirs[i].history.distanceX, source % 24 - x) << i;
    EXPECT_EQ(reservoirs[i].history.distanceY, source / 24 - y) << i;
    const int sx = source % 24, sy = source / 24;
    EXPECT_EQ(sx >= 12, x >= 12) << "pixel " << i << " took its sample from the other half, pixel " << source;
    EXPECT_LE(std::hypot(sx - x, sy - y), params.radius + 0.71) << "pixel " << i << " from pixel " << source;
  }
  EXPECT_GT(combined, static_cast<int>(reservoirs.size()) / 2);
}

TEST(SpatialReuse, WhereTemporalReuseFailedMoreNeighboursAreCombined) {
  test::HandMadeFrame f(32, 16);
  ReservoirBuffer initial, spare;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(5), initial, stats);
  SpatialParams params;
  params.enabled = true;
  params.neighbours = 2;
  params.disocclusionNeighbours = 10;
  params.radius = 6.0f;
  params.disocclusionBoost = true;  // as the pipeline sets it when temporal reuse runs
  auto meanConfidence = [&](uint8_t accepted) {
    ReservoirBuffer r = initial;
    const std::vector<uint8_t> temporalAccepted(r.size(), accepted);
    SpatialReuse(params, f.View(5), temporalAccepted, r, spare, stats);
    double sum = 0.0;
    for (const StoredReservoir& x : r) sum += x.confidence;
    return sum / r.size();
  };
  const double accepted = meanConfidence(1), failed = meanConfidence(0);
  EXPECT_LE(accepted, 3.0);
  EXPECT_GT(failed, 6.0);
  params.disocclusionBoost = false;  // temporal reuse off: no pixel failed it, whatever the buffer says
  EXPECT_EQ(meanConfidence(0), accepted);
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// RTXDI's discountNaiveSamples: a neighbour with a sample and confidence <= 2 never enters the combination, so no
// pixel takes its sample and its confidence is not added; without the setting the same neighbours are combined.
TEST(SpatialReuse, DiscountingNaiveSamplesSkipsNeighboursWithoutHistory) {
  test::HandMadeFrame f(24, 12);
  ReservoirBuffer initial, spare;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(4), initial, stats);
  // Every third pixel is naive (confidence 1 or 2); the others carry history (confidence 3, RTXDI's M > 2).
  for (size_t i = 0; i < initial.size(); ++i) initial[i].confidence = i % 3 == 0 ? float(1 + i % 2) : 3.0f;
  SpatialParams params;
  params.enabled = true;
  params.mis = MisFamily::kUniform;
  params.neighbours = 8;
  params.radius = 4.0f;
  for (bool discount : {false, true}) {
    params.discountNaiveSamples = discount;
    ReservoirBuffer reservoirs = initial;
    SpatialReuse(params, f.View(4), {}, reservoirs, spare, stats);
    int fromNaive = 0;
    for (size_t i = 0; i < reservoirs.size(); ++i) {
      if (!reservoirs[i].HasSample()) continue;
      for (size_t j = 0; j < initial.size(); ++j)
        if (j != i && initial[j].position == reservoirs[i].position && initial[j].lightId == reservoirs[i].lightId)
          fromNaive += initial[j].confidence <= kNaiveConfidence;
      // Confidence is its own plus whole neighbours' confidences: with the discount, only multiples of 3 are added.
      if (discount) {
        EXPECT_EQ(std::fmod(reservoirs[i].confidence - initial[i].confidence, 3.0f), 0.0f) << i;
      }
    }
    if (discount)
      EXPECT_EQ(fromNaive, 0);
    else
      EXPECT_GT(fromNaive, 10);  // without it, naive neighbours' samples are taken
  }
}

}  // namespace
}  // namespace restir
