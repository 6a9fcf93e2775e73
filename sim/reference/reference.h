// The converged reference (DESIGN §7): unbiased direct lighting at each G-buffer pixel with per-pixel light
// selection (core/light_selection_kernel.h: each light group's unshadowed contribution there, Lambert's formula on
// its polygon or a point estimate, beside a defensive share by power; a quad light's two triangles are one group),
// uniform area sampling and one shadow ray per sample, combined by MIS with BSDF sampling on glossy surfaces. The
// pixels of a row are taken in blocks of 16 (core/light_selection_kernel.h kSelectionBlock): their distributions
// are built together, one pixel per SIMD lane, and their samples drawn by the light-draw and BSDF-draw kernels,
// their shadow rays traced as one batch of packets (sim/reference/reference_samples.h). Under a sky (an environment,
// a sun: issue 18) light sampling is a per-pixel mixture of the local lights, the sun and the environment
// (sim/reference/reference_sky.h), BSDF sampling runs on every surface, and pixels whose primary ray escaped show the
// sky. A pilot pass estimates each pixel's relative variance and learns, per tile, how much of each light group's
// and sky strategy's unshadowed contribution its shadow rays let through (sim/reference/reference_learning.h); the
// main pass draws from the distributions reshaped by it and spends the samples in proportion to the variance. At a
// diffuse receiver without a sky, the lights its pilot saw arrive are taken as their exact unshadowed contribution
// minus a sampled estimate of what their shadows take (the difference estimator, sim/reference/reference_learning.h),
// so that an unoccluded diffuse receiver is exact.
// Samples are randomised quasi-Monte Carlo in 16 independent replicates, so the reference also reports an honest
// per-pixel standard error. Cached on disk.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "sim/reference/reference_cache.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/util/image.h"
#include "sim/scene/sequence.h"

namespace restir {

struct ReferenceParams {
  // Mean direct-lighting samples per pixel, the pilot's 16 included; the main pass's per-pixel counts are
  // multiples of 16 (replicates) in proportion to the pilot's relative variance. Ignored when
  // targetRelativeError > 0.
  int samplesPerPixel = 1024;
  // When > 0 (--reference-error): each pixel gets the samples its pilot says it needs for this relative standard
  // error (between 16 and 65536), instead of a share of a fixed budget.
  double targetRelativeError = 0.0;
  // With targetRelativeError: the most samples a frame may take, as a mean per pixel over the pixels that take
  // samples, the pilot's included (the sequence's referenceSppCap, --reference-cap). When the target would cost
  // more, the frame spends the cap as a fixed budget (the same bits as samplesPerPixel = the cap) and reports that
  // it was capped (ReferenceImage::allocation). In samples rather than seconds so that a capped reference has the
  // same bits on every machine. 0: no cap.
  int maxMeanSamplesPerPixel = 0;
  std::string cacheDir;  // where converged frames are kept; empty: no cache
  // Reshape the main pass's light selection by the visibility the pilot's shadow rays found, per tile
  // (sim/reference/reference_learning.h). Off only to measure what it gains (bench/reference_quality_bench.cpp):
  // the distributions are then the unshadowed ones.
  bool learnVisibility = true;
  // At diffuse receivers of a frame without a sky, with per-pixel light distributions and the learning on: take
  // the light groups the pixel's pilot saw arrive as their exact unshadowed contribution minus a sampled estimate
  // of what their shadows take (sim/reference/reference_learning.h, the difference estimator), so that an
  // unoccluded diffuse receiver is exact. Off only to measure what it gains (bench/reference_quality_bench.cpp,
  // RESTIR_BENCH_REFERENCE_DIFFERENCE=0).
  bool differenceShadows = true;
  // Under the difference estimator: draw a differenced group's points by (nearly) their projected solid angle
  // (core/polygon_light_sampling.h) instead of uniformly by area. Off: measured, it hardly lowers the variance (a
  // differenced draw's noise is whether its ray arrives, not how f / p varies over the light) and costs a third more
  // time (docs/metrics.md "The difference estimator"). On only to measure that (RESTIR_BENCH_REFERENCE_PSA=1).
  bool projectedSolidAngleDraws = false;
  // Raise each pixel's pilot relative variance to its neighbourhood's mean where that is larger, before the
  // allocation (sim/reference/reference_learning.h SpreadRelativeVariance). Off only to measure what it gains
  // (bench/reference_quality_bench.cpp, RESTIR_BENCH_REFERENCE_SPREAD=0). In the cache key.
  bool spreadRelativeVariance = true;
  // With indirect light: draw each path's first direction from the mixture of x₁'s BSDF and what the pilot's paths
  // found per guide tile (sim/reference/reference_guide.h). Off only to measure what it gains
  // (bench/reference_quality_bench.cpp, RESTIR_BENCH_REFERENCE_GUIDE=0). In the cache key.
  bool guidePaths = true;
  // Added to the reference's seed: another value renders the same frame from independent random numbers (a test
  // comparing two estimators needs them independent). In the cache key.
  uint32_t seed = 0;
  // Indirect light (issue 41): the most surfaces after the primary hit that a path's light may reflect at before
  // it reaches the pixel, 0 to kMaxIndirectBounces (sim/reference/reference_paths.h); 0: direct light only, the
  // reference as it was. Paths are counted like the direct samples (samplesPerPixel, or the error target and its
  // cap), each part held to the target / √2 so that together they reach it. In the cache key where it is not 0.
  int indirectBounces = 0;
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
  uint64_t samples = 0;     // direct-lighting samples taken, the pilot's included (0 when cached)
  uint64_t paths = 0;       // indirect paths traced (ReferenceParams::indirectBounces), the pilot's included (0 when cached)
  std::vector<uint32_t> pixelSamples;  // per pixel, the samples it took, pilot included (empty when cached)
  ReferenceAllocation allocation;      // how the samples were spent (cached with the images)
};

// Renders (or reads from the cache) the reference of the scene's current frame, at the G-buffer's pixels.
ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& gbuffer, const ReferenceParams& params);

// A hash of everything in a frame state that changes the image: camera (with resolution), object transforms,
// light states, and the sky's intensities, rotation and sun direction when the frame has a sky (a skyless frame
// hashes as it did before the sky existed).
uint64_t HashFrameState(const FrameState& state);

// The cache key: a hash of everything that changes the reference image (sequence content, frame state, samples,
// renderer version). Not the frame index: identical states share one reference.
std::string ReferenceCacheKey(const Sequence& sequence, const FrameState& state, const ReferenceParams& params);

// The most samples one pixel's main pass can take with these parameters (the pilot's 16 are drawn in a pass of their
// own): the allocation's cap, 16 times the mean in budget mode, 65536 with a target error.
double ReferenceMaxSamplesPerPixel(const ReferenceParams& params);

// The most RenderReference allocates while it runs beyond its result and its kept distributions, for a frame of
// `pixels` pixels and `lights` light triangles in `groups` light groups, no pixel taking more than
// `maxSamplesPerPixel` samples (the workers' scratch, a block's samples at once among it, and the pilot's per-pixel
// state, with each pixel's light mixture when the frame has a sky, and what the pilot learned per tile); for the
// run's memory estimate (sim/run/memory_estimate.h). `width`: the frame's, for its learning tiles per row (0: a
// square frame's).
double ReferenceScratchBytes(double pixels, double lights, double groups, double maxSamplesPerPixel,
                             bool sky = false, double width = 0.0);

// The pilot's per-pixel light distributions kept for the main pass, for a frame of width × height pixels and
// `groups` light groups: 0 where they would pass kKeptDistributionBytes (then the main pass builds them again).
// They stay with the process between frames (a later frame of the same size reuses them instead of faulting in
// fresh pages), so the run's memory estimate counts them as long-lived.
double ReferenceKeptBytes(double width, double height, double groups);

// Mean over lit pixels (reference luminance > 1e-4) of the luminance's standard error / the luminance: the
// reference's own relative noise.
double MeanRelativeStandardError(const ReferenceImage& ref);

// The reference's noise as issue 40's goals state it: over lit pixels (luminance > 1e-4), the mean and the 99th
// percentile of the relative standard error of the luminance; and the pixels that took samples yet came out exactly
// black with every replicate agreeing (a surface whose samples found no light: either truly unlit, or lit by a light
// the reference never reached, which only a closed form or another reference can tell).
struct ReferenceConvergence {
  double meanRelative = 0.0;  // MeanRelativeStandardError
  double p99Relative = 0.0;   // 99th percentile over lit pixels (nearest rank)
  size_t litPixels = 0;       // pixels with luminance > 1e-4
  size_t darkSampled = 0;     // pixels with samples (pixelSamples > 0) whose estimate and standard error are 0
};
ReferenceConvergence MeasureReferenceConvergence(const ReferenceImage& ref);

// The index of the q-quantile of `count` sorted values by nearest rank (ceil(q · count) − 1, within [0, count − 1]),
// as p99Relative takes it, so that a study or a benchmark quoting a reference's percentile takes the same one.
inline size_t NearestRankIndex(size_t count, double q) {
  const double rank = std::ceil(q * double(count));
  return rank < 1.0 ? 0 : std::min(count - 1, static_cast<size_t>(rank) - 1);
}

}  // namespace restir
