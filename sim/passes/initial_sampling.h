// Initial sampling (DESIGN §2 InitialSampling; seed 003 §1): streaming RIS over M light candidates per pixel,
// optionally with a visibility ray for the selected sample (Bitterli 2020).
#pragma once

#include "core/light_sampler.h"
#include "sim/passes/frame_view.h"

namespace restir {

struct InitialSamplingParams {
  int candidates = 32;                                     // M light candidates per pixel (streaming RIS)
  LightSelection lightSelection = LightSelection::kPower;  // source distribution over lights
  bool visibility = false;                                 // trace the selected sample; occluded -> W = 0, V = 0
  bool countCandidates = false;  // confidence counts candidates (seed 003 representedM) instead of 1 per frame
};

// Writes one reservoir per pixel into `out` (resized to the frame): the RIS reservoir of every surface pixel, an
// empty one elsewhere. Runs the RIS kernel (core/ris_kernel.h) a row at a time; a row's visibility rays go to
// Embree as one batch.
void InitialSampling(const InitialSamplingParams& params, const FrameView& view, ReservoirBuffer& out,
                     PassStats& stats);

}  // namespace restir
