// The stochastic pairwise pass alone on a hand-made frame (sim/estimator/passes/stochastic_pairwise_reuse.h): cells
// group a tile's pixels by object and normal bin; a pixel's output confidence is its own plus its chosen cell's,
// scaled by N/M (seed 004 §4.3); its sample comes from itself or from a pixel of one cell of the same surface.
#include "sim/estimator/passes/stochastic_pairwise_reuse.h"

#include <gtest/gtest.h>

#include <cmath>

#include "hand_made_frame.h"
#include "sim/estimator/passes/initial_sampling.h"
#include "sim/estimator/passes/spatial_reuse.h"

namespace restir {
namespace {

TEST(BuildCells, GroupsEachTilesPixelsByObjectAndNormal) {
  test::HandMadeFrame f(16, 8);
  // Right tile: its lower half another object, and one pixel of the upper half another orientation.
  for (int y = 4; y < 8; ++y)
    for (int x = 8; x < 16; ++x) f.gbuffer.objectId[y * 16 + x] = 9;
  f.gbuffer.ngX[1 * 16 + 10] = 1, f.gbuffer.ngY[1 * 16 + 10] = 0;
  ReservoirBuffer reservoirs(f.gbuffer.Size());
  for (size_t i = 0; i < reservoirs.size(); ++i) reservoirs[i].confidence = float(i % 3 + 1);
  StochasticPairwiseParams params;
  params.cellTile = 8;
  CellGrid grid;
  BuildCells(f.gbuffer, reservoirs, params, grid);
  ASSERT_EQ(grid.cells.size(), 4u);  // left tile: 1; right tile: object 7 up, its odd pixel, object 9
  size_t pixels = 0;
  for (size_t c = 0; c < grid.cells.size(); ++c) {
    const CellGrid::Cell& cell = grid.cells[c];
    float confidence = 0.0f;
    for (uint32_t t = 0; t < cell.count; ++t) {
      const uint32_t p = grid.pixels[cell.first + t];
      EXPECT_EQ(grid.pixelCell[p], static_cast<int32_t>(c));
      EXPECT_EQ(f.gbuffer.objectId[p], cell.objectId);
      if (t > 0) {
        EXPECT_LT(grid.pixels[cell.first + t - 1], p);  // scan order
      }
      confidence += reservoirs[p].confidence;
    }
    EXPECT_FLOAT_EQ(cell.confidenceSum, confidence);
    pixels += cell.count;
  }
  EXPECT_EQ(pixels, f.gbuffer.Size());
  EXPECT_EQ(grid.cells[0].count, 64u);
  EXPECT_EQ(grid.cells[1].count, 31u);
  EXPECT_EQ(grid.cells[2].count, 1u);
  EXPECT_EQ(grid.cells[3].count, 32u);
}

TEST(StochasticPairwiseReuse, OutputConfidenceIsTheCanonicalsPlusTheScaledCell) {
  test::HandMadeFrame f(16, 16);
  ReservoirBuffer reservoirs, spare;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(9), reservoirs, stats);
  const ReservoirBuffer input = reservoirs;
  SpatialParams params;
  params.enabled = true;
  params.mis = MisFamily::kStochasticPairwise;
  params.bias = BiasCorrection::kRayTraced;
  params.stochastic.draws = 5;
  params.stochastic.canonicalDraws = 5;
  params.stochastic.cellTile = 8;
  params.stochastic.cellSearchRadius = 4.0f / 16.0f;  // 4 px
  CellGrid grid;
  StochasticPairwiseReuse(params, f.View(9), {}, reservoirs, spare, grid, stats);
  EXPECT_EQ(stats.name, "spatial");
  EXPECT_EQ(grid.cells.size(), 4u);
  EXPECT_GT(stats.rays, 0u);  // ray-traced targets
  for (size_t i = 0; i < reservoirs.size(); ++i) {
    // Every cell has 64 pixels of confidence 1: M = 63 candidates besides the pixel itself (or 64 for a pixel of
    // another cell), scaled by N/M, so the cell counts N = 5 whatever M.
    EXPECT_NEAR(reservoirs[i].confidence, 1.0f + 5.0f, 1e-5f) << i;
    ASSERT_TRUE(reservoirs[i].HasSample()) << i;
    int source = -1;
    for (size_t j = 0; j < input.size(); ++j)
      if (input[j].position == reservoirs[i].position) source = int(j);
    ASSERT_GE(source, 0) << i;
  }
}

// The stochastic pass on the 16×16 floor: confidence 1 everywhere (initial sampling), the given tile and search.
struct CellRun {
  test::HandMadeFrame f{16, 16};
  ReservoirBuffer reservoirs, spare;
  PassStats stats;
  SpatialParams params;
  CellGrid grid;
  CellRun(int tile, float radiusPixels) {
    InitialSampling(InitialSamplingParams{}, f.View(9), reservoirs, stats);
    params.enabled = true;
    params.mis = MisFamily::kStochasticPairwise;
    params.bias = BiasCorrection::kRayTraced;
    params.stochastic.cellTile = tile;
    params.stochastic.cellSearchRadius = radiusPixels / 16.0f;
  }
  void Run(const std::vector<uint8_t>& temporalAccepted = {}) {
    stats = PassStats{};
    StochasticPairwiseReuse(params, f.View(9), temporalAccepted, reservoirs, spare, grid, stats);
  }
};

// Issue 39: the search radius is in image heights, and its default is seed 004's 30 px at 1080 rows, exactly, so
// the radii of the iterations (× cellSearchGrowth each) are the paper's there; at 360 rows a third of them.
TEST(StochasticPairwiseReuse, CellSearchRadiusIsThePapersAt1080Rows) {
  const StochasticPairwiseParams p;
  EXPECT_EQ(CellSearchRadiusPixels(p, 1080), 30.0f);
  EXPECT_EQ(p.cellSearchGrowth, 1.25f);
  EXPECT_EQ(p.cellSearchIterations, 12);
  EXPECT_NEAR(CellSearchRadiusPixels(p, 360), 10.0f, 1e-5f);
  EXPECT_NEAR(CellSearchRadiusPixels(p, 2160), 60.0f, 1e-4f);
}

// N > M (2×2 tiles: M = 3 candidates in the pixel's own cell, 4 in another, N = 5 draws): the N/M factor is
// capped at 1, so the cell counts its own Σ c and no more; uncapped it would claim 5 either way.
TEST(StochasticPairwiseReuse, ACellSmallerThanNCountsOnlyItsOwnConfidence) {
  CellRun r(2, 1.0f);
  r.params.stochastic.draws = 5;
  r.Run();
  EXPECT_EQ(r.grid.cells.size(), 64u);
  for (size_t i = 0; i < r.reservoirs.size(); ++i) {
    const float c = r.reservoirs[i].confidence;
    EXPECT_TRUE(std::abs(c - 4.0f) < 1e-5f || std::abs(c - 5.0f) < 1e-5f) << i << ": " << c;
  }
}

// The disocclusion boost: pixels whose temporal reuse failed (the left half) draw disocclusionDraws = 10, the
// others draws = 5, and the cell they stand for counts N (8×8 tiles: M = 63 > N).
TEST(StochasticPairwiseReuse, PixelsWhoseTemporalReuseFailedDrawDisocclusionDraws) {
  CellRun r(8, 4.0f);
  r.params.stochastic.draws = 5;
  r.params.stochastic.disocclusionDraws = 10;
  std::vector<uint8_t> accepted(r.reservoirs.size());
  for (size_t i = 0; i < accepted.size(); ++i) accepted[i] = i % 16 >= 8;
  const ReservoirBuffer initial = r.reservoirs;
  r.params.disocclusionBoost = false;  // without the boost the mask is not read
  r.Run(accepted);
  for (size_t i = 0; i < accepted.size(); ++i) EXPECT_NEAR(r.reservoirs[i].confidence, 6.0f, 1e-5f) << i;
  r.reservoirs = initial;
  r.params.disocclusionBoost = true;
  r.Run(accepted);
  for (size_t i = 0; i < accepted.size(); ++i)
    EXPECT_NEAR(r.reservoirs[i].confidence, accepted[i] ? 6.0f : 11.0f, 1e-5f) << i;
}

// A pixel whose search finds no similar cell keeps its reservoir and is counted; so is a k-neighbour pixel none
// of whose neighbours qualifies (a normal threshold above 1 rejects every surface).
TEST(StochasticPairwiseReuse, FailedSearchesAreCounted) {
  CellRun r(8, 4.0f);
  r.Run();
  EXPECT_EQ(r.stats.failed, 0u);
  EXPECT_EQ(r.stats.visited, 256u);
  // Its own reservoir and the 63 others of its cell (or 64 of another) per pixel, plus the cell build's 256.
  EXPECT_GE(r.stats.reservoirReads, 256u * 64u + 256u);
  EXPECT_LE(r.stats.reservoirReads, 256u * 65u + 256u);
  const ReservoirBuffer before = r.reservoirs;
  r.params.normalThreshold = 1.5f;
  r.Run();
  EXPECT_EQ(r.stats.failed, 256u);
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(r.reservoirs[i].confidence, before[i].confidence) << i;

  SpatialParams k = r.params;
  k.mis = MisFamily::kPairwise;
  PassStats stats;
  SpatialReuse(k, r.f.View(9), {}, r.reservoirs, r.spare, stats);
  EXPECT_EQ(stats.failed, 256u);
  EXPECT_EQ(stats.visited, 256u);
  k.normalThreshold = 0.9f;
  k.radius = 3.0f;
  stats = PassStats{};
  SpatialReuse(k, r.f.View(9), {}, r.reservoirs, r.spare, stats);
  EXPECT_LT(stats.failed, 16u);  // only pixels whose 5 draws all fell off the frame or on themselves
}

}  // namespace
}  // namespace restir
