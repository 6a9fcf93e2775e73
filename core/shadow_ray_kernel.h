// Shadow-ray setup kernel: for a batch of visibility queries (receiver x with geometric normal ng, light point
// y on an emitter of normal ny), the segment core/shadow_ray.h ShadowRaySetup builds, so the passes set up a whole batch of rays in one call
// instead of one scalar MakeShadowRay per query (about 13 per pixel per frame).
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch, a packet of
// queries per register) and its scalar twin built from ShadowRaySetup. Same bits on every target.
#pragma once

#include <cstddef>

namespace restir {

// The queries, structure-of-arrays (x y z each).
struct ShadowRayInputs {
  const float* position[3] = {};         // x
  const float* geometricNormal[3] = {};  // ng at x, either orientation (the ray picks its side)
  const float* errorScale = nullptr;     // x's error scale (sim/scene/gbuffer.h GBuffer::errorScale)
  const float* lightPosition[3] = {};    // y
  const float* lightNormal[3] = {};      // the emitter's normal at y, either orientation
  const float* lightErrorScale = nullptr;  // y's error scale (core/light.h LightTriangle::errorScale)
  size_t count = 0;
};

// One entry per query. Any NaN is written as std::numeric_limits<float>::quiet_NaN(): its payload would
// otherwise depend on how the compiler ordered the operands, not on the inputs (core/target_kernel.cpp
// CanonicalNaN). Outputs must not overlap the inputs.
struct ShadowRayOutputs {
  float* org[3] = {};
  float* dir[3] = {};  // unit
  float* tmax = nullptr;
};

// Runs the kernel on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar).
void SetupShadowRays(const ShadowRayInputs& in, const ShadowRayOutputs& out);

// The scalar twin, callable directly (tests and benchmarks).
void SetupShadowRaysScalar(const ShadowRayInputs& in, const ShadowRayOutputs& out);

// Name of the Highway target SetupShadowRays runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* ShadowRayKernelDispatchedTargetName();

}  // namespace restir
