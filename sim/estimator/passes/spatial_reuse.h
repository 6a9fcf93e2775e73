// Spatial reuse from k screen-space neighbours (DESIGN §2 SpatialReuse, §4 "Spatial reuse"): each pixel's
// reservoir combined by GRIS with those of random similar neighbours in a disk, more where temporal reuse
// failed; one or more iterations, each reading the previous one's output.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mis.h"
#include "core/rng.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/passes/spatial_common.h"

namespace restir {

// params.iterations passes over `reservoirs` (updated in place); `spare` is a second buffer the iterations
// alternate with (its contents are lost). With params.disocclusionBoost, `temporalAccepted` (one per pixel) marks
// the pixels whose temporal reuse succeeded and the others get disocclusionNeighbours; without, it is not read
// (may be empty). params.visibility is what the shading pass will use: with a carried visibility, a neighbour's V
// is re-traced from this pixel (seed 000 Algorithm 1).
void SpatialReuse(const SpatialParams& params, const FrameView& view, const std::vector<uint8_t>& temporalAccepted,
                  ReservoirBuffer& reservoirs, ReservoirBuffer& spare, PassStats& stats);


}  // namespace restir
