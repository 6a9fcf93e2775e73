// The converged reference (DESIGN §7): unbiased direct lighting at each G-buffer pixel with light selection
// by power, uniform area sampling and one shadow ray per sample, combined by MIS with BSDF sampling on glossy
// surfaces. Samples are randomised quasi-Monte Carlo in 16 independent replicates, so the reference also
// reports an honest per-pixel standard error. Cached on disk.
#pragma once

#include <cstdint>
#include <string>

#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/image.h"
#include "sim/sequence.h"

namespace restir {

struct ReferenceParams {
  int samplesPerPixel = 1024;  // direct-lighting samples per pixel, rounded up to a multiple of 16 (replicates)
  std::string cacheDir;        // where converged frames are kept; empty: no cache
};

struct ReferenceImage {
  ImageRgb mean;            // the reference radiance
  ImageRgb standardError;   // per pixel and channel: spread of 16 independent replicate means / sqrt(16)
  // Per pixel, the same for the luminance Y of the replicate means. Not Y(standardError): the channels' errors are
  // correlated (one light sample feeds all three), so only the replicates know Y's variance.
  std::vector<float> lumaStandardError;
  bool fromCache = false;   // read from the cache rather than rendered
  double ms = 0.0;          // wall time (render or cache read)
  uint64_t rays = 0;        // rays traced (0 when cached)
};

// Renders (or reads from the cache) the reference of the scene's current frame, at the G-buffer's pixels.
ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& gbuffer, const ReferenceParams& params);

// A hash of everything in a frame state that changes the image: camera (with resolution), object transforms,
// light states.
uint64_t HashFrameState(const FrameState& state);

// The cache key: a hash of everything that changes the reference image (sequence content, frame state, samples,
// renderer version). Not the frame index: identical states share one reference.
std::string ReferenceCacheKey(const Sequence& sequence, const FrameState& state, int spp);

// Mean over lit pixels (reference luminance > 1e-4) of the luminance's standard error / the luminance: the
// reference's own relative noise.
double MeanRelativeStandardError(const ReferenceImage& ref);

}  // namespace restir
