// What the two spatial passes share (sim/estimator/passes/spatial_reuse.h, stochastic_pairwise_reuse.h): the
// spatial.* settings and the random-number key of a pixel's spatial draws.
#pragma once

#include "core/mis.h"
#include "core/rng.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

// What the cell pass adds to the spatial settings (they are the spatial.* keys draws, canonicalDraws, ...).
struct StochasticPairwiseParams {
  int draws = 5;                   // N: non-canonical draws with replacement, P(i) ∝ c_i p̂_i(X_i) W_i (Eq. 17)
  int canonicalDraws = 5;          // N_c: uniform draws estimating the canonical weight (Eq. 18-19)
  int cellTile = 8;                // tile size in pixels; a cell is a tile's pixels with one object and normal bin
  int normalBins = 4;              // octahedral normal quantisation: bins x bins orientation classes
  int cellSearchIterations = 12;   // weighted-reservoir neighbour-cell search iterations (§5.1)
  float cellSearchRadius = 30.0f;  // first search radius in pixels
  float cellSearchGrowth = 1.25f;  // radius factor per iteration
  bool confidenceScaling = true;   // scale non-canonical confidences (and c̄) by N/M (§4.3)
};

// The spatial.* settings. mis selects the pass: stochastic-pairwise runs StochasticPairwiseReuse, every other
// family SpatialReuse.
struct SpatialParams {
  bool enabled = false;                          // reuse from screen-space neighbours
  MisFamily mis = MisFamily::kUniform;           // MIS family of the (1 + k)-input combination
  BiasCorrection bias = BiasCorrection::kBasic;  // how targets enter the MIS weights
  int neighbours = 5;                            // k neighbours per pixel
  int disocclusionNeighbours = 10;               // k where temporal reuse failed (disocclusion boost)
  float radius = 30.0f;                          // neighbour radius in pixels
  int iterations = 1;                            // passes, each reading a copy of the previous one's output
  float normalThreshold = 0.9f;                  // minimum dot of the neighbour's and the pixel's normals
  float depthThreshold = 0.1f;                   // maximum relative view-depth difference
  // RTXDI's discountNaiveSamples (rtxdi-runtime DI/SpatialResampling.hlsli): a neighbour whose reservoir holds a
  // sample but has confidence <= kNaiveConfidence (RTXDI_NAIVE_SAMPLING_M_THRESHOLD: this frame's candidates with
  // at most a frame of history) is skipped, so fresh samples are not spread. k-neighbour pass only.
  bool discountNaiveSamples = false;
  StochasticPairwiseParams stochastic;           // the cell pass's own settings (mis = stochastic-pairwise)
};

inline constexpr float kNaiveConfidence = 2.0f;

// The RNG key of pixel i in spatial iteration `iteration` (DESIGN §3): both spatial passes draw from it.
RngKey SpatialRngKey(const FrameView& view, size_t i, int iteration);

}  // namespace restir
