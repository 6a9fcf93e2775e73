// Spatial reuse by stochastic pairwise MIS over screen-space cells (seed 004 §3-5; DESIGN §4): each pixel picks a
// neighbouring cell by weighted reservoir search, draws N of its pixels by contribution and N_c uniformly, and
// combines their reservoirs with unbiased stochastic estimates of the pairwise MIS weights.
#pragma once

#include <cstdint>
#include <vector>

#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/passes/spatial_common.h"

namespace restir {

inline constexpr int kMaxCellTile = 32;  // a cell holds at most kMaxCellTile² pixels
inline constexpr int kMaxCellPixels = kMaxCellTile * kMaxCellTile;
inline constexpr int kMaxCellSearchIterations = 64;  // bound on StochasticPairwiseParams::cellSearchIterations

// Screen-space cells (seed 004 §5): each tile's surface pixels grouped by (object id, quantised normal), in tile
// and scan order so the lists never depend on the thread count.
struct CellGrid {
  struct Cell {
    int32_t objectId = -1;    // shared object id of its pixels
    uint32_t key = 0;         // PCG hash of (tile, object id, quantised normal)
    Vec3 normal{0.0f};        // normalised mean geometric normal
    uint32_t first = 0;       // its pixels: pixels[first, first + count)
    uint32_t count = 0;
    float confidenceSum = 0;  // Σ c_i over its pixels (weights the neighbour-cell search)
  };
  std::vector<Cell> cells;
  std::vector<int32_t> pixelCell;  // per pixel: its cell, or -1
  std::vector<uint32_t> pixels;    // pixel indices grouped by cell, in scan order within a cell
  int width = 0;                   // the frame's width: pixel index -> (x, y)
};

// Builds the cells of a frame from its G-buffer and the confidences of `reservoirs`.
void BuildCells(const GBuffer& g, const ReservoirBuffer& reservoirs, const StochasticPairwiseParams& params,
                CellGrid& grid);

// spatial.iterations passes over `reservoirs` (updated in place); `spare` is a second buffer the iterations
// alternate with (its contents are lost). `cells` holds the last iteration's cells afterwards. Reads params.bias,
// params.iterations, params.normalThreshold, params.stochastic and params.visibility (what the shading pass will
// use; sim/estimator/passes/spatial_common.h). With params.disocclusionBoost, `temporalAccepted` (one per pixel)
// marks the pixels whose temporal reuse succeeded and the others draw stochastic.disocclusionDraws; without, it is
// not read (may be empty).
void StochasticPairwiseReuse(const SpatialParams& params, const FrameView& view,
                             const std::vector<uint8_t>& temporalAccepted, ReservoirBuffer& reservoirs,
                             ReservoirBuffer& spare, CellGrid& cells, PassStats& stats);

}  // namespace restir
