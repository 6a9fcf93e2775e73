// RTXDI's boiling filter (sim/estimator/passes/temporal_reuse.h BoilingFilter) against thresholds worked out by hand
// from rtxdi-runtime's rule: per 16×16 tile, empty the reservoirs whose W exceeds the mean of the tile's
// nonzero W times 10/s − 9. Tiles are independent (partial ones at the edges included), zeros do not dilute
// the mean, and the result does not depend on the thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <random>

#include "sim/estimator/passes/temporal_reuse.h"

namespace restir {
namespace {

ReservoirBuffer Uniform(int w, int h, float W) {
  ReservoirBuffer r(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < r.size(); ++i) {
    r[i].W = W;
    r[i].lightId = 1;
    r[i].targetPdf = 1.0f;
    r[i].confidence = 5.0f;
    r[i].position = Vec3(float(i), 0.0f, 0.0f);
  }
  return r;
}

TEST(BoilingFilter, EmptiesOnlyTheOutliersAboveTheTilesThreshold) {
  // One full tile of W = 1 with one heavy sample h: mean of the 256 nonzero W = (255 + h) / 256, strength
  // 0.2: threshold 41 × mean. h = 1000: 201 (emptied); h = 150: 64.9 (emptied); h = 40: 47.2 (kept).
  for (const auto& [heavy, expect] : {std::pair{1000.0f, 1u}, std::pair{150.0f, 1u}, std::pair{40.0f, 0u}}) {
    ReservoirBuffer r = Uniform(16, 16, 1.0f);
    r[37].W = heavy;
    EXPECT_EQ(BoilingFilter(0.2f, 16, 16, r), expect) << heavy;
    EXPECT_EQ(r[37].W, expect ? 0.0f : heavy) << heavy;
    for (size_t i = 0; i < r.size(); ++i)
      if (i != 37) { EXPECT_EQ(r[i].W, 1.0f) << i; }
  }
  // Just below and just above the threshold at strength 0.5 (multiplier 11): 255 ones and one h, h vs 11 (255
  // + h) / 256, equal at h = 2805 / 245 = 11.449.
  for (const auto& [heavy, expect] : {std::pair{11.40f, 0u}, std::pair{11.50f, 1u}}) {
    ReservoirBuffer r = Uniform(16, 16, 1.0f);
    r[200].W = heavy;
    EXPECT_EQ(BoilingFilter(0.5f, 16, 16, r), expect) << heavy;
  }
}

TEST(BoilingFilter, EmptiedReservoirsAreRtxdisEmptyReservoir) {
  ReservoirBuffer r = Uniform(16, 16, 1.0f);
  r[5].W = 1e6f;
  r[5].history.age = 9;
  ASSERT_EQ(BoilingFilter(0.2f, 16, 16, r), 1u);
  EXPECT_FALSE(r[5].HasSample());
  EXPECT_EQ(r[5].confidence, 0.0f);  // M = 0: it carries no history either
  EXPECT_EQ(r[5].history.age, 0u);
}

TEST(BoilingFilter, ZerosDoNotDiluteTheMeanAndTilesAreIndependent) {
  // A 37 x 21 frame: tiles of 16, 16 and 5 columns, 16 and 5 rows.
  const int w = 37, h = 21;
  ReservoirBuffer r(static_cast<size_t>(w) * h);  // all empty
  auto at = [&](int x, int y) -> StoredReservoir& { return r[static_cast<size_t>(y) * w + x]; };
  // Tile (0, 0): two samples, W 1 and 100: mean 50.5. Strength 1 (multiplier 1) empties the 100 only; counted
  // over all 256 pixels the mean would be 0.39 and would empty both.
  at(3, 4).W = 1.0f, at(9, 2).W = 100.0f;
  // Tile (2, 1), the 5 x 5 corner: W 2, 2, 3: mean 7/3; the 3 is above it at strength 1.
  at(33, 17).W = 2.0f, at(36, 20).W = 2.0f, at(32, 16).W = 3.0f;
  // Tile (1, 0): a single sample is its own mean and never above it.
  at(20, 7).W = 1e9f;
  EXPECT_EQ(BoilingFilter(1.0f, w, h, r), 2u);
  EXPECT_EQ(at(3, 4).W, 1.0f);
  EXPECT_EQ(at(9, 2).W, 0.0f);
  EXPECT_EQ(at(33, 17).W, 2.0f);
  EXPECT_EQ(at(36, 20).W, 2.0f);
  EXPECT_EQ(at(32, 16).W, 0.0f);
  EXPECT_EQ(at(20, 7).W, 1e9f);
}

TEST(BoilingFilter, OffAtZeroStrengthAndTheSameBitsOnOneAndTwoThreads) {
  ReservoirBuffer r = Uniform(64, 48, 1.0f);
  std::mt19937 rng(7);
  std::lognormal_distribution<float> heavyTail(0.0f, 2.5f);  // a few W far above their tile's mean
  for (StoredReservoir& x : r) x.W = heavyTail(rng);
  ReservoirBuffer off = r;
  EXPECT_EQ(BoilingFilter(0.0f, 64, 48, off), 0u);
  for (size_t i = 0; i < r.size(); ++i) ASSERT_EQ(off[i].W, r[i].W);
  ReservoirBuffer one = r, two = r;
  size_t n1, n2;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    n1 = BoilingFilter(0.2f, 64, 48, one);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    n2 = BoilingFilter(0.2f, 64, 48, two);
  }
  EXPECT_GT(n1, 0u);   // the heavy tail has outliers
  EXPECT_LT(n1, 60u);  // and only a few
  EXPECT_EQ(n1, n2);
  for (size_t i = 0; i < r.size(); ++i) ASSERT_EQ(one[i].W, two[i].W) << i;
}

}  // namespace
}  // namespace restir
