// Shading (DESIGN §2 Shade): each pixel's estimate f(Y) W from its final reservoir, with a final shadow ray or the
// carried visibility (seed 000 Algorithm 1), plus what the primary ray sees directly.
#pragma once

#include <cmath>

#include "sim/util/image.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

struct ShadeParams {
  VisibilityReuse visibility = VisibilityReuse::kNone;  // final shadow ray, or the carried visibility
  // RTXDI's final-visibility reuse (reuseFinalVisibility; rtxdi-runtime DI/Reservoir.hlsli
  // RTXDI_GetDIReservoirVisibility), with a final shadow ray only: the visibility a shadow ray found is stored in the
  // reservoir (its visibilityAge and distance reset), and a later frame shades with it instead of tracing when
  // 0 < visibilityAge <= finalVisibilityMaxAge and the distance moved is under finalVisibilityMaxDistance pixels.
  // Biased by design where occluders or lights move: stale visibility.
  bool reuseFinalVisibility = false;
  int finalVisibilityMaxAge = 4;             // frames (RTXDI's default)
  float finalVisibilityMaxDistance = 16.0f;  // pixels (RTXDI's default)
  // RTXDI's discardInvisibleSamples (RTXDI_StoreVisibilityInDIReservoir): a sample the final shadow ray finds
  // occluded is removed from the reservoir kept for the next frame (W = 0, confidence 0); this frame's image is
  // unchanged. What makes the temporal visibility shortcut safe. Biased: history is lost where the sample was.
  bool discardInvisibleSamples = false;
};

// Writes the frame's image (resized to the G-buffer). Non-finite pixels are written as 0 and counted in
// stats.guarded (DESIGN §10). With final-visibility reuse it also stores each traced visibility in `reservoirs`
// (their visibility and history; nothing else changes), as RTXDI's shading pass writes its reservoirs back.
void Shade(const ShadeParams& params, const FrameView& view, ReservoirBuffer& reservoirs, ImageRgb& image,
           PassStats& stats);

// RTXDI_GetDIReservoirVisibility's test: the reservoir's stored visibility may stand in for a shadow ray.
inline bool StoredVisibilityUsable(const SampleHistory& h, const ShadeParams& params) {
  const float d = std::sqrt(float(h.distanceX) * float(h.distanceX) + float(h.distanceY) * float(h.distanceY));
  return h.visibilityAge > 0 && h.visibilityAge <= params.finalVisibilityMaxAge &&
         d < params.finalVisibilityMaxDistance;
}

}  // namespace restir
