// Initial sampling's candidate sources beyond the RIS kernel's local lights (issue 18; DESIGN §4 "Candidate
// sources"): the sun, the environment map and BSDF rays, combined with the local lights by multiple-importance
// RIS (core/candidates.h). Scalar, per pixel, after the RIS kernel has streamed the local lights at SIMD speed (a
// frame without these sources keeps the kernel's old bits); they add a few candidates per pixel and a BSDF ray each.
#pragma once

#include <cstdint>

#include "core/candidates.h"
#include "core/reservoir.h"
#include "core/shading.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {


// True when the frame needs the mixed path: a sky to sample or BSDF candidates. Otherwise initial sampling is the
// RIS kernel alone, bit for bit as before the sky existed.
bool NeedsCandidateSources(const CandidateCounts& counts);

// The candidates of one receiver (G-buffer pixel `pixel`) into a reservoir, finalised (W = Σ w / p̂(Y); the
// confidence is left to the caller). `kernelLocal` is the RIS kernel's streamed local-light reservoir (weights
// p̂ / p_area over counts.local candidates): it enters as one GRIS input whose MIS weight against the BSDF source is
// evaluated at its selected point only (see the .cpp); null when the frame has no local lights. The random numbers
// come from RngPass::kInitialSources, so they never meet the kernel's.
// `lights` is the local-light source distribution (power or uniform, InitialSamplingParams::lightSelection).
Reservoir SampleCandidateSources(const FrameView& view, const LightSampler& lights, const CandidateCounts& counts,
                                 float brdfCutoff, const ShadingPoint& sp, uint32_t pixel,
                                 const Reservoir* kernelLocal, uint64_t& rays);

}  // namespace restir
