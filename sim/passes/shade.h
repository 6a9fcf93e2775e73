// Shading (DESIGN §2 Shade): each pixel's estimate f(Y) W from its final reservoir, with a final shadow ray or the
// carried visibility (seed 000 Algorithm 1), plus what the primary ray sees directly.
#pragma once

#include "sim/image.h"
#include "sim/passes/frame_view.h"

namespace restir {

struct ShadeParams {
  VisibilityReuse visibility = VisibilityReuse::kNone;  // final shadow ray, or the carried visibility
};

// Writes the frame's image (resized to the G-buffer). Non-finite pixels are written as 0 and counted in
// stats.guarded (DESIGN §10).
void Shade(const ShadeParams& params, const FrameView& view, const ReservoirBuffer& reservoirs, ImageRgb& image,
           PassStats& stats);

}  // namespace restir
