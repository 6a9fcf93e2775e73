// Light-draw kernel (issue 16): the converged reference's light-sampling step (sim/reference/reference.cpp) for one
// receiver and a batch of draws, a packet of draws per register. Draw k picks a light by inverting the
// receiver's light distribution over light groups (core/sampling.h SampleSplitCdf at uSelect[k]), takes the point
// SampleTrianglePoint(uPoint0[k], uPoint1[k]) on it, and gives the light-sampling estimate's term f / p (f =
// core/shading.h UnshadowedContribution, p = CdfPmf × (1 / the group's area), the area density) with the shadow ray that
// decides whether it counts (core/shadow_ray.h ShadowRaySetup). Only the draws whose term can count (f nonzero,
// p positive) are written, packed in draw order with their index, as the shadow-ray batch the caller traces
// (EmbreeScene::OccludedBatch of ShadowRaysSoa). For a receiver that also samples its BSDF
// (bsdfMis), the term carries the power heuristic's weight against core/bsdf.h PdfBsdf, as the reference's
// light-sampling half of MIS; the BSDF half stays the caller's.
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin built from the core functions. Same bits on every target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/bsdf.h"
#include "core/light.h"
#include "core/math.h"

namespace restir {

// The receiver, as sim/scene/shading_point.h ShadingPointAt builds it.
struct LightDrawReceiver {
  Vec3 position;           // x
  Vec3 geometricNormal;    // facing the viewer
  Vec3 shadingNormal;      // n, facing the viewer
  Vec3 wo;                 // unit, towards the viewer
  float errorScale = 0;    // x's error scale (sim/scene/gbuffer.h GBuffer::errorScale)
  int32_t materialId = 0;  // index into the BsdfSoa
  bool bsdfMis = false;    // weight each term by PowerHeuristic(p in solid angle, PdfBsdf), else by 1
};

// Floats per light record: p0, e1, e2, normal (x y z each), radiance (r g b) (core/light.h LightTriangle), and
// 1 / the area of the triangle's group (core/light.h LightGroups), which the area density multiplies by.
inline constexpr size_t kLightDrawRecordFloats = 16;

// The frame's light triangles: per light one 64-byte record (SIMD targets load it whole and transpose), and
// the error scale beside it; and the groups the cdf selects (core/light.h LightGroups).
struct LightDrawLights {
  const float* records = nullptr;     // kLightDrawRecordFloats per triangle, 64-byte aligned (WriteLightDrawRecord)
  const float* errorScale = nullptr;  // per triangle, LightTriangle::errorScale
  size_t count = 0;                   // triangles
  const uint32_t* groupFirst = nullptr;  // per group: its first triangle
  const float* groupSplit = nullptr;     // per group: its first triangle's share of its area, 2 for a lone one
  size_t groups = 0;                     // groups; the cdf has this many entries
};

// Light t's record into record[0, kLightDrawRecordFloats) (invArea: 1 / its group's area), and back.
inline void WriteLightDrawRecord(const LightTriangle& t, float invArea, float* record) {
  for (int c = 0; c < 3; ++c) {
    record[c] = t.p0[c];
    record[3 + c] = t.e1[c];
    record[6 + c] = t.e2[c];
    record[9 + c] = t.normal[c];
    record[12 + c] = t.radiance[c];
  }
  record[15] = invArea;
}
inline LightTriangle ReadLightDrawRecord(const float* record, float& invArea) {
  LightTriangle t;
  for (int c = 0; c < 3; ++c) {
    t.p0[c] = record[c];
    t.e1[c] = record[3 + c];
    t.e2[c] = record[6 + c];
    t.normal[c] = record[9 + c];
    t.radiance[c] = record[12 + c];
  }
  invArea = record[15];
  return t;
}

// The draws' uniforms in [0, 1), one array per dimension.
struct LightDraws {
  const float* uSelect = nullptr;  // inverts the cdf
  const float* uPoint0 = nullptr;  // SampleTrianglePoint's u0
  const float* uPoint1 = nullptr;  // SampleTrianglePoint's u1
  size_t count = 0;                // draws
};

// Every draw's term, at its index k; and one ray per draw that counts (f is nonzero and p positive: its term counts
// if its ray is unoccluded), packed in draw order from index 0: the kernel returns how many. Each array holds at
// least draws.count entries. Any NaN is written as std::numeric_limits<float>::quiet_NaN() (core/math.h
// CanonicalNaN).
struct LightDrawOutputs {
  float* term[3] = {};       // per draw k: f / p, r g b, where the draw counts; else 0
  float* org[3] = {};        // the shadow ray's origin
  float* dir[3] = {};        // its unit direction
  float* tmax = nullptr;     // its length
  uint32_t* draw = nullptr;  // the draw's index k, plus firstDraw
  uint32_t firstDraw = 0;    // added to every index written (a caller numbering several receivers' draws as one list)
};

// Runs the kernel on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar) and returns the
// number of draws that count. `cdf` holds lights.groups cumulative values, non-decreasing, the last positive.
size_t DrawLightSamples(const LightDrawReceiver& receiver, const BsdfSoa& materials,
                      const LightDrawLights& lights, const float* cdf, const LightDraws& draws,
                      const LightDrawOutputs& out);

// The scalar twin, callable directly (tests and benchmarks).
size_t DrawLightSamplesScalar(const LightDrawReceiver& receiver, const BsdfSoa& materials,
                            const LightDrawLights& lights, const float* cdf, const LightDraws& draws,
                            const LightDrawOutputs& out);

// Name of the Highway target DrawLightSamples runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* LightDrawKernelDispatchedTargetName();

}  // namespace restir
