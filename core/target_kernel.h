// Target-evaluation kernel (DESIGN §2 "TemporalReuse", "SpatialReuse", "Shade"; issue 6): for a batch of
// (receiver, light point) pairs, the unshadowed contribution L_e f_r G and its target p̂ = luminance
// (core/shading.h UnshadowedContribution, TargetFunction). It is the arithmetic of every GRIS combination
// (p̂_j(Y_i) for each MIS family, in each input's frame), of stochastic pairwise weights and of final shading;
// the passes gather the pairs a row needs, evaluate them here in one call, and trace the rays of the entries
// that need visibility in one batch.
//
// Two implementations beside each other, as core/ris_kernel.h: a Highway kernel (dynamic dispatch, a packet of
// pairs per register) and its scalar twin built from the core functions. Same bits on every target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/bsdf.h"

namespace restir {

// The pairs, structure-of-arrays. The receiver's wo is normalize(eye - x), as sim/scene/shading_point.cpp
// ShadingPointAt.
struct TargetPairs {
  const float* eye[3] = {};              // camera position of the receiver's frame
  const float* position[3] = {};         // x
  const float* geometricNormal[3] = {};  // facing the viewer
  const float* shadingNormal[3] = {};    // n, facing the viewer
  const int32_t* materialId = nullptr;   // index into BsdfSoa
  const float* lightPosition[3] = {};    // p_y
  const float* lightNormal[3] = {};      // n_y
  const float* radiance[3] = {};         // L_e(y) in the receiver's frame (zero for a light switched off)
  size_t count = 0;                      // pairs
};

// Any NaN result is written as std::numeric_limits<float>::quiet_NaN(): its payload would otherwise depend on
// how the compiler ordered the operands, not on the inputs (core/target_kernel.cpp CanonicalNaN).
// The float arrays of a TargetPairs, in the order MakeTargetPairs takes them: eye, position, geometric normal,
// shading normal, light position, light normal, radiance (x y z each).
inline constexpr int kTargetPairFields = 21;

// A TargetPairs over `fields[0..kTargetPairFields)` in the order above.
inline TargetPairs MakeTargetPairs(const float* const* fields, const int32_t* materialId, size_t count) {
  TargetPairs p;
  for (int c = 0; c < 3; ++c) {
    p.eye[c] = fields[c];
    p.position[c] = fields[3 + c];
    p.geometricNormal[c] = fields[6 + c];
    p.shadingNormal[c] = fields[9 + c];
    p.lightPosition[c] = fields[12 + c];
    p.lightNormal[c] = fields[15 + c];
    p.radiance[c] = fields[18 + c];
  }
  p.materialId = materialId;
  p.count = count;
  return p;
}

struct TargetResults {
  float* target = nullptr;          // p̂ = TargetFunction(UnshadowedContribution(sp, y)) per pair
  float* contribution[3] = {};      // L_e f_r G per pair, r g b; all three null: not written
};

// Runs the kernel on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar).
void EvaluateTargets(const TargetPairs& pairs, const BsdfSoa& materials, const TargetResults& out);

// The scalar twin, callable directly (tests and benchmarks).
void EvaluateTargetsScalar(const TargetPairs& pairs, const BsdfSoa& materials, const TargetResults& out);

// Name of the Highway target EvaluateTargets runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* TargetKernelDispatchedTargetName();

}  // namespace restir
