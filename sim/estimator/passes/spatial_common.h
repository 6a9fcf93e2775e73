// What the two spatial passes share (sim/estimator/passes/spatial_reuse.h, stochastic_pairwise_reuse.h): the
// spatial.* settings, the random-number key of a pixel's spatial draws, and the skeleton both run (their
// iterations over the two reservoir buffers, batch by batch, and their statistics).
#pragma once

#include <cstdint>
#include <functional>

#include "core/gris.h"
#include "core/mis.h"
#include "core/rng.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

// How the N_c canonical draws pick a cell pixel j (seed 004 Eq. 18-19 hold for any P_c that is positive wherever
// c_j > 0). Uniform is the paper's; ∝ c_j is the alternative it names: the term of a draw, K_c c_j/(N_c P_c) ·
// (...), then carries C = Σ c_j whatever j, so a draw of a low-confidence pixel no longer weighs M times its share.
enum class CanonicalPdf {
  kUniform,     // P_c(j) = 1/M
  kConfidence,  // P_c(j) = c_j / Σ_k c_k (zero-confidence pixels, whose terms are 0, are never drawn)
};

// What the cell pass adds to the spatial settings (they are the spatial.* keys draws, canonicalDraws, ...).
struct StochasticPairwiseParams {
  int draws = 5;                   // N: non-canonical draws with replacement, P(i) ∝ c_i p̂_i(X_i) W_i (Eq. 17)
  // N where temporal reuse failed (with SpatialParams::disocclusionBoost): the counterpart of the k-neighbour
  // pass's disocclusionNeighbours, so both methods shift as many candidates in the revealed region (issue 39).
  int disocclusionDraws = 10;
  int canonicalDraws = 5;          // N_c: draws estimating the canonical weight (Eq. 18-19)
  CanonicalPdf canonicalPdf = CanonicalPdf::kUniform;  // P_c of the canonical draws
  int cellTile = 8;                // tile size in pixels; a cell is a tile's pixels with one object and normal bin
  int normalBins = 4;              // octahedral normal quantisation: bins x bins orientation classes
  int cellSearchIterations = 12;   // weighted-reservoir neighbour-cell search iterations (§5.1)
  // First search radius in image heights: the paper's 30 px at 1080 rows (CellSearchRadiusPixels), so the search
  // covers the same share of the image at any resolution.
  float cellSearchRadius = 30.0f / 1080.0f;
  float cellSearchGrowth = 1.25f;  // radius factor per iteration
  bool confidenceScaling = true;   // scale non-canonical confidences (and c̄) by min(1, N/M) (§4.3)
};

// The first cell-search radius in pixels of an image `height` rows high.
inline float CellSearchRadiusPixels(const StochasticPairwiseParams& params, int height) {
  return params.cellSearchRadius * static_cast<float>(height);
}

// The spatial.* settings, and two facts other passes decide, which the pipeline fills in where it is built
// (sim/estimator/pipeline.h PassSettings). mis selects the pass: stochastic-pairwise runs StochasticPairwiseReuse,
// every other family SpatialReuse.
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
  // Not settings (sim/estimator/settings.cpp lists neither): filled by the pipeline from the other passes' structs.
  // shade.visibility. Why here: the shading pass decides what visibility reuse must carry (with carried V a
  // neighbour's V is re-traced from the pixel, seed 000 Algorithm 1), and the pass reads it from its own struct.
  VisibilityReuse visibility = VisibilityReuse::kNone;
  // temporal.enabled: pixels whose temporal reuse failed take disocclusionNeighbours (the cell pass:
  // stochastic.disocclusionDraws). Why: without a temporal pass no pixel failed it, and its all-zero acceptance
  // must not boost every pixel.
  bool disocclusionBoost = false;
};

inline constexpr float kNaiveConfidence = 2.0f;

// The RNG key of pixel i in spatial iteration `iteration` (DESIGN §3): both spatial passes draw from it.
RngKey SpatialRngKey(const FrameView& view, size_t i, int iteration);

struct BatchScratch;  // sim/estimator/passes/batching.h

// One batch of one spatial iteration, as RunSpatialIterations hands it to a pass.
struct SpatialBatch {
  const FrameView& view;         // the frame
  const GBuffer& g;              // *view.gbuffer
  int iteration;                 // 0 .. params.iterations - 1 (SpatialRngKey's iteration)
  int y, x0, x1;                 // the batch: pixels [x0, x1) of row y
  const ReservoirBuffer& input;  // the previous iteration's output (the pass's input in iteration 0)
  ReservoirBuffer& output;       // this iteration's output: the batch writes each of its pixels
  VisibilityCarry carry;         // how combinations carry visibility for the shading pass (CarryFor)
  bool carryVisibility;          // the shading pass uses carried V: neighbours' V is re-traced (seed 000 Alg. 1)
  BatchScratch& scratch;         // this thread's combinations, combiner and evaluator (bound to the frame)
  uint64_t& rays;                // this thread's count of shadow rays traced
  uint64_t& guarded;             // this thread's count of non-finite values caught and reset (DESIGN §10)
  uint64_t& reservoirReads;      // this thread's count of reservoirs read (PassStats::reservoirReads)
  uint64_t& failed;              // this thread's count of surface pixels left without reuse (PassStats::failed)
};

// The skeleton of both spatial passes: params.iterations iterations, each reading `reservoirs` (the previous
// iteration's output) and writing every pixel of `spare`, then swapping the two (the pipeline's ping-pong: no third
// buffer, Pipeline::kReservoirBuffers); an iteration's batches run in parallel (ForEachBatch), each with its
// thread's scratch, its evaluator bound to the current frame (ray traced with params.bias = ray-traced). Ends with
// the pass's statistics under the name "spatial" (with the batches' reservoir reads and failed pixels). `beginIteration` (may be empty) runs before an iteration's
// batches with its input; `batch` does one batch. Reads params.iterations, params.bias and params.visibility.
void RunSpatialIterations(const SpatialParams& params, const FrameView& view, ReservoirBuffer& reservoirs,
                          ReservoirBuffer& spare, PassStats& stats,
                          const std::function<void(const ReservoirBuffer& input)>& beginIteration,
                          const std::function<void(const SpatialBatch& batch)>& batch);

}  // namespace restir
