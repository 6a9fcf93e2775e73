// Initial-sampling kernel (DESIGN §2 "InitialSampling", §4 streaming RIS; issue 6): for a run of receivers, M
// light candidates each from the light sampler, the unshadowed target p̂ of each, and streaming RIS over them.
// The caller finalises each pixel's reservoir with FinalizeRis and traces the initial visibility ray.
//
// Two implementations beside each other: a Highway kernel (dynamic dispatch over SSE4, AVX2, AVX-512: a packet
// of pixels per register) and its scalar twin (plain C++ built from the same core functions the pipeline used
// before: LightSampler::Sample, UnshadowedContribution, StreamCandidate). Both give the same bits on every
// target (DESIGN §3): per-lane IEEE operations only, in the scalar code's order, no FMA, no approximations.
// core/simd.h chooses which one runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/bsdf.h"
#include "core/light_sampler.h"
#include "core/simd.h"

namespace restir {

// The receivers of a run of pixels, structure-of-arrays. Element k is pixel pixelBase + k of the RNG key.
struct RisPixels {
  const float* position[3] = {};         // x, world space (x y z arrays)
  const float* geometricNormal[3] = {};  // facing the viewer
  const float* shadingNormal[3] = {};    // n, facing the viewer
  const float* wo[3] = {};               // unit direction towards the viewer (normalize(camera - x))
  const int32_t* materialId = nullptr;   // index into BsdfSoa; read only where active
  const uint8_t* active = nullptr;       // nonzero: run RIS for this pixel; zero: output an empty reservoir
  uint32_t pixelBase = 0;                // RNG pixel index of element 0
  size_t count = 0;                      // pixels in the run
};

struct RisParams {
  uint32_t seed = 0;        // RngKey::seed
  uint32_t frame = 0;       // RngKey::frame
  uint32_t pass = 0;        // RngKey::pass (RngPass::kInitial in the pipeline)
  int candidates = 32;      // M; candidate j draws dimensions 5j..5j+4 (uSelect, uCoin, uPoint0, uPoint1, uSel)
};

// Per pixel, SoA: the streamed reservoir before FinalizeRis. Pixels that selected nothing (or are inactive) get
// lightId 0 and zeros everywhere, as a default Reservoir.
struct RisOutput {
  int32_t* lightId = nullptr;     // LightSample::lightId
  float* position[3] = {};        // LightSample::position
  float* normal[3] = {};          // LightSample::normal
  float* radiance[3] = {};        // LightSample::radiance
  float* pdfArea = nullptr;       // LightSample::pdfArea
  float* weightSum = nullptr;     // Reservoir::weightSum
  float* targetPdf = nullptr;     // Reservoir::targetPdf
};

// Runs the kernel on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar). `lights` must be
// non-empty whenever a pixel is active.
void RisInitialSampling(const RisPixels& pixels, const LightSamplerSoa& lights, const BsdfSoa& materials,
                        const RisParams& params, const RisOutput& out);

// The scalar twin, callable directly (tests and benchmarks).
void RisInitialSamplingScalar(const RisPixels& pixels, const LightSamplerSoa& lights,
                              const BsdfSoa& materials, const RisParams& params, const RisOutput& out);

// Name of the Highway target the dispatched (non-scalar) kernel runs on now, e.g. "AVX3" (tests).
const char* RisKernelDispatchedTargetName();

}  // namespace restir
