// The stochastic pairwise pass alone on a hand-made frame (sim/estimator/passes/stochastic_pairwise_reuse.h): cells
// group a tile's pixels by object and normal bin; a pixel's output confidence is its own plus its chosen cell's,
// scaled by N/M (seed 004 §4.3); its sample comes from itself or from a pixel of one cell of the same surface.
#include "sim/estimator/passes/stochastic_pairwise_reuse.h"

#include <gtest/gtest.h>

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
  params.stochastic.cellSearchRadius = 4.0f;
  CellGrid grid;
  StochasticPairwiseReuse(params, f.View(9), reservoirs, spare, grid, stats);
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

}  // namespace
}  // namespace restir
