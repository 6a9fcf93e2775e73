// BSDF-draw kernel (issue 16): the BSDF-sampling half of the converged reference's direct lighting at a receiver
// that is not diffuse (sim/reference/reference.cpp), a packet of draws per register. Draw k samples a direction from
// the receiver's BSDF (core/bsdf.h SampleBsdf at u0[k], u1[k]) and gives the ray that looks for a light along it
// (from core/shadow_ray.h OffsetRayOrigin, unbounded) with the sample's throughput f_r(wi) cos θi / p(wi) and its
// density p(wi). Only the draws that can count (p > 0, wi above the geometric normal) are written, packed in draw
// order with their index. What the ray finds (an emitter's radiance, the light strategy's density there for the power
// heuristic) is the caller's.
//
// Two implementations beside each other, as core/light_draw_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin built from the core functions. Same bits on every target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/bsdf.h"
#include "core/light_draw_kernel.h"  // LightDrawReceiver

namespace restir {

// The draws' uniforms in [0, 1), one array per dimension.
struct BsdfDraws {
  const float* u0 = nullptr;  // SampleBsdf's u0 (the lobe's polar angle, and the layered model's lobe choice)
  const float* u1 = nullptr;  // SampleBsdf's u1 (the azimuth)
  size_t count = 0;           // draws
};

// One entry per draw that counts, in draw order from index 0; the kernel returns how many. Each array holds at
// least draws.count entries. Any NaN is written as std::numeric_limits<float>::quiet_NaN().
struct BsdfDrawOutputs {
  float* org[3] = {};        // the ray's origin, off the receiver on wi's side
  float* dir[3] = {};        // wi, unit
  float* weight[3] = {};     // f_r(wo, wi) cos θi / p(wi), r g b
  float* pdf = nullptr;      // p(wi), solid angle
  uint32_t* draw = nullptr;  // the draw's index k, plus firstDraw
  uint32_t firstDraw = 0;    // added to every index written
};

// Runs the kernel on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar) and returns the
// number of draws that count. receiver.bsdfMis is ignored.
size_t DrawBsdfSamples(const LightDrawReceiver& receiver, const BsdfSoa& materials, const BsdfDraws& draws,
                       const BsdfDrawOutputs& out);

// The scalar twin, callable directly (tests and benchmarks).
size_t DrawBsdfSamplesScalar(const LightDrawReceiver& receiver, const BsdfSoa& materials, const BsdfDraws& draws,
                             const BsdfDrawOutputs& out);

// Name of the Highway target DrawBsdfSamples runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* BsdfDrawKernelDispatchedTargetName();

}  // namespace restir
