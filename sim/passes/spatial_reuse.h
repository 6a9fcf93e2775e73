// Spatial reuse from k screen-space neighbours (DESIGN §2 SpatialReuse, §4 "Spatial reuse"): each pixel's
// reservoir combined by GRIS with those of random similar neighbours in a disk, more where temporal reuse
// failed; one or more iterations, each reading the previous one's output.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mis.h"
#include "core/rng.h"
#include "sim/passes/frame_view.h"
#include "sim/passes/stochastic_pairwise_reuse.h"

namespace restir {

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

// params.iterations passes over `reservoirs` (updated in place); `spare` is a second buffer the iterations
// alternate with (its contents are lost). `temporalAccepted` (null: temporal reuse is off) marks the pixels whose
// temporal reuse succeeded; the others get disocclusionNeighbours. `visibility` is what the shading pass will
// use: with a carried visibility, a neighbour's V is re-traced from this pixel (seed 000 Algorithm 1).
void SpatialReuse(const SpatialParams& params, VisibilityReuse visibility, const FrameView& view,
                  const std::vector<uint8_t>* temporalAccepted, ReservoirBuffer& reservoirs, ReservoirBuffer& spare,
                  PassStats& stats);

// The RNG key of pixel i in spatial iteration `iteration` (DESIGN §3): both spatial passes draw from it.
RngKey SpatialRngKey(const FrameView& view, size_t i, int iteration);

}  // namespace restir
