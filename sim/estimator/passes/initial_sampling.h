// Initial sampling (DESIGN §2 InitialSampling; seed 003 §1): streaming RIS over M light candidates per pixel,
// optionally with a visibility ray for the selected sample (Bitterli 2020).
#pragma once

#include "core/light_sampler.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

// The most candidates any one source draws per pixel (--set validates it): each source's random numbers live in a
// dimension range of their own (sim/estimator/passes/candidate_sources.cpp) that this many candidates fit in.
inline constexpr int kMaxCandidatesPerSource = 4096;

struct InitialSamplingParams {
  int candidates = 32;                                     // M light candidates per pixel (streaming RIS)
  LightSelection lightSelection = LightSelection::kPower;  // source distribution over lights
  bool visibility = false;                                 // trace the selected sample; occluded -> W = 0, V = 0
  bool countCandidates = false;  // confidence counts candidates (seed 003 representedM) instead of 1 per frame
  // Candidate sources beyond local lights (DESIGN §4; core/candidates.h), RTXDI's initial sampling counts. A
  // source with nothing to sample in a frame draws nothing; with none of them, initial sampling is the RIS kernel
  // over `candidates` local lights alone.
  int sunCandidates = 1;          // directions in the sun's cone (RTXDI numPrimaryInfiniteLightSamples)
  int environmentCandidates = 1;  // directions from the environment map (RTXDI numPrimaryEnvironmentSamples)
  int brdfCandidates = 0;         // BSDF-sampled rays to an emitter or the sky (RTXDI numPrimaryBrdfSamples)
  float brdfCutoff = 0.0f;        // shortens BSDF rays, RTXDI's brdfCutoff (core/candidates.h BrdfRayMaxDistance)

  // Equal parameters draw equal reservoirs from equal frames (sim/estimator/pipeline.h InitialSamplingShare).
  friend bool operator==(const InitialSamplingParams&, const InitialSamplingParams&) = default;
};

// Writes one reservoir per pixel into `out` (resized to the frame): the RIS reservoir of every surface pixel, an
// empty one elsewhere. Runs the RIS kernel (core/ris_kernel.h) a row at a time, then, where the frame has a sky or
// BSDF candidates are asked for, the other sources (sim/estimator/passes/candidate_sources.h); a row's visibility
// rays go to Embree as one batch.
void InitialSampling(const InitialSamplingParams& params, const FrameView& view, ReservoirBuffer& out,
                     PassStats& stats);

}  // namespace restir
