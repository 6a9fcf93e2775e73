// Temporal reuse (DESIGN §2 TemporalReuse; seed 003 §3-5): each pixel's reservoir combined by GRIS with the
// previous frame's reservoir at its reprojected pixel, validated and confidence-capped.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mis.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

struct TemporalParams {
  bool enabled = false;                          // reuse the previous frame's reservoir
  MisFamily mis = MisFamily::kUniform;           // MIS family of the two-input combination
  BiasCorrection bias = BiasCorrection::kBasic;  // how targets enter the MIS weights
  float maxHistory = 20.0f;                      // cap on the previous reservoir's confidence (seed 003 §4.3;
                                                 // core/temporal.h CappedHistoryConfidence)
  bool sampleChecks = true;    // seed 003's sample tests: reject an empty previous reservoir or p̂_c(Y_prev) = 0
                               // (they depend on the sample, so unbiased presets turn them off)
  bool targetRatioClamp = false;  // also reject unless p̂_c(Y_prev) / p̂_prev(Y_prev) is in [0.1, 10]
                                  // (core/temporal.h TargetRatioInRange)
  bool permutation = false;       // RTXDI permutation sampling: read a per-frame XOR-permuted previous pixel
  // RTXDI's boiling filter, run on the pass's output (rtxdi-runtime DI/BoilingFilter.hlsli, Utils/BoilingFilter.hlsli):
  // in each kBoilingFilterTile² tile, a reservoir whose W exceeds the tile's mean nonzero W times 10/s − 9 is
  // emptied. s in (0, 1]; 0 turns it off. RTXDI's default is 0.2 (a threshold of 41× the mean). Biased by design:
  // it removes rare, heavy samples before spatial reuse spreads them into a flash.
  float boilingFilterStrength = 0.0f;
  // RTXDI's enableVisibilityShortcut (DI/TemporalResampling.hlsli): with ray-traced bias correction, the previous
  // sample is taken as visible at the previous surface, without a ray. RTXDI calls it safe only when the previous
  // frame discarded its invisible samples (shade.discardInvisibleSamples); biased otherwise.
  bool visibilityShortcut = false;
  // RTXDI's fused spatiotemporal resampling (DI/SpatioTemporalResampling.hlsli): the temporal combination also
  // takes up to `fusedNeighbours` reservoirs of the previous frame around the reprojected pixel (uniform in a disk
  // of fusedRadius pixels, the same surface by RTXDI's default thresholds), each with its previous-frame domain, so
  // one pass does both reuses; a preset using it turns the spatial pass off. 0: the plain temporal pass.
  int fusedNeighbours = 0;
  float fusedRadius = 32.0f;  // pixels (RTXDI's default sampling radius)
  // Not a setting (sim/estimator/settings.cpp does not list it): shade.visibility, filled by the pipeline where it
  // is built (sim/estimator/pipeline.h PassSettings). Why here: the shading pass decides how the combination must
  // carry visibility (CarryFor), and the pass reads it from its own struct.
  VisibilityReuse visibility = VisibilityReuse::kNone;
};

// RTXDI's boiling-filter group: the 16×16 thread group its temporal pass runs in (RTXDI_BOILING_FILTER_GROUP_SIZE).
inline constexpr int kBoilingFilterTile = 16;

// The boiling filter on `reservoirs` (one per pixel of a width × height frame, row-major): tiles of
// kBoilingFilterTile² pixels from the top-left corner (partial at the right and bottom edges); per tile, the mean
// m of the W > 0 among its reservoirs (summed in pixel order), then every reservoir with W > m (10/s − 9) emptied.
// Returns the number emptied. Does nothing for strength <= 0.
size_t BoilingFilter(float strength, int width, int height, ReservoirBuffer& reservoirs);

// Combines `current` (this frame's reservoirs, updated in place) with `previous` (last frame's output, one per
// pixel of the previous G-buffer). `accepted` (resized to the frame) marks the pixels whose previous reservoir
// entered the combination. Without history (the view has no previous frame, or `previous` does not match it)
// nothing changes. params.visibility is what the shading pass will use, which decides how visibility is carried.
void TemporalReuse(const TemporalParams& params, const FrameView& view, const ReservoirBuffer& previous,
                   ReservoirBuffer& current, std::vector<uint8_t>& accepted, PassStats& stats);

}  // namespace restir
