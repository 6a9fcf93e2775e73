// Highway kernel, scalar twin and dispatcher of the target-evaluation kernel (core/target_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): the kernel is core/shading-inl.h's lane-wise copy of the scalar equations, plus the
// receiver's wo = glm::normalize(eye - x) in GLM's own expression (NormalizeV), so every target reproduces the
// twin bit for bit. NaN results are the one exception the source cannot pin down; both sides canonicalise them
// (CanonicalNaN).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/target_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <cmath>
#include <limits>

#include "core/shading-inl.h"
#include "core/shading.h"
#include "core/simd.h"
#include "core/target_kernel.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {

// Every float input field of TargetPairs, so that offsetting and padding treat them all alike.
using PairField = const float* (TargetPairs::*)[3];
constexpr PairField kPairFields[] = {&TargetPairs::eye,           &TargetPairs::position,
                                     &TargetPairs::geometricNormal, &TargetPairs::shadingNormal,
                                     &TargetPairs::lightPosition,   &TargetPairs::lightNormal,
                                     &TargetPairs::radiance};
constexpr int kPairFieldCount = static_cast<int>(sizeof(kPairFields) / sizeof(kPairFields[0]));

// Pairs [0, Lanes) of `p`, whose pointers start at the packet's first pair. `rgb` is null when not wanted.
HWY_INLINE void TargetPacket(const TargetPairs& p, const BsdfSoa& mt, float* target, float* const* rgb) {
  const DF df;
  const DI di;
  VF eye[3], x[3], ng[3], n[3], y[3], ny[3], radiance[3];
  for (int c = 0; c < 3; ++c) {
    eye[c] = hn::LoadU(df, p.eye[c]);
    x[c] = hn::LoadU(df, p.position[c]);
    ng[c] = hn::LoadU(df, p.geometricNormal[c]);
    n[c] = hn::LoadU(df, p.shadingNormal[c]);
    y[c] = hn::LoadU(df, p.lightPosition[c]);
    ny[c] = hn::LoadU(df, p.lightNormal[c]);
    radiance[c] = hn::LoadU(df, p.radiance[c]);
  }
  // sim/estimator/pipeline.cpp ShadingPointAt's wo, as the twin computes it.
  VF toEye[3], wo[3];
  for (int c = 0; c < 3; ++c) toEye[c] = hn::Sub(eye[c], x[c]);
  NormalizeV(toEye, wo);
  const ShadingPointV sp = MakeShadingPointV(x, ng, n, wo, GatherBsdfV(mt, hn::LoadU(di, p.materialId)));
  const LightPathV path = ConnectToLightV(sp, y, ny);
  VF f[3];
  UnshadowedContributionV(sp, path, radiance, f);
  hn::StoreU(CanonicalNaNV(LuminanceV(f)), df, target);
  if (rgb != nullptr)
    for (int c = 0; c < 3; ++c) hn::StoreU(CanonicalNaNV(f[c]), df, rgb[c]);
}

void TargetKernel(const TargetPairs& pairs, const BsdfSoa& materials, const TargetResults& out) {
  const DF df;
  const size_t N = hn::Lanes(df);
  const bool wantRgb = out.contribution[0] != nullptr;
  auto shifted = [&](size_t k) {
    TargetPairs p = pairs;
    for (PairField f : kPairFields)
      for (int c = 0; c < 3; ++c) (p.*f)[c] += k;
    p.materialId += k;
    return p;
  };

  size_t k = 0;
  for (; k + N <= pairs.count; k += N) {
    float* rgb[3] = {};
    if (wantRgb)
      for (int c = 0; c < 3; ++c) rgb[c] = out.contribution[c] + k;
    TargetPacket(shifted(k), materials, out.target + k, wantRgb ? rgb : nullptr);
  }
  if (k == pairs.count) return;

  // Tail: a full packet would read and write past the caller's arrays, so run one on a padded copy. The padding
  // lanes are zeros with the first pair's material (a valid index), and their results are dropped.
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = pairs.count - k;
  HWY_ALIGN float inF[kPairFieldCount][3][kMax] = {};
  HWY_ALIGN int32_t inMat[kMax];
  const TargetPairs src = shifted(k);
  TargetPairs padded = src;
  for (int f = 0; f < kPairFieldCount; ++f) {
    for (int c = 0; c < 3; ++c) {
      for (size_t l = 0; l < rest; ++l) inF[f][c][l] = (src.*kPairFields[f])[c][l];
      (padded.*kPairFields[f])[c] = inF[f][c];
    }
  }
  for (size_t l = 0; l < kMax; ++l) inMat[l] = src.materialId[l < rest ? l : 0];
  padded.materialId = inMat;
  HWY_ALIGN float outTarget[kMax];
  HWY_ALIGN float outRgb[3][kMax];
  float* rgb[3] = {outRgb[0], outRgb[1], outRgb[2]};
  TargetPacket(padded, materials, outTarget, wantRgb ? rgb : nullptr);
  for (size_t l = 0; l < rest; ++l) {
    out.target[k + l] = outTarget[l];
    if (wantRgb)
      for (int c = 0; c < 3; ++c) out.contribution[c][k + l] = outRgb[c][l];
  }
}

const char* TargetKernelTargetName() { return hwy::TargetName(HWY_TARGET); }

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(TargetKernel);
HWY_EXPORT(TargetKernelTargetName);

namespace {


}  // namespace

void EvaluateTargetsScalar(const TargetPairs& p, const BsdfSoa& materials, const TargetResults& out) {
  const bool rgb = out.contribution[0] != nullptr;
  for (size_t k = 0; k < p.count; ++k) {
    ShadingPoint sp;
    sp.position = Vec3(p.position[0][k], p.position[1][k], p.position[2][k]);
    sp.geometricNormal = Vec3(p.geometricNormal[0][k], p.geometricNormal[1][k], p.geometricNormal[2][k]);
    sp.shadingNormal = Vec3(p.shadingNormal[0][k], p.shadingNormal[1][k], p.shadingNormal[2][k]);
    sp.wo = glm::normalize(Vec3(p.eye[0][k], p.eye[1][k], p.eye[2][k]) - sp.position);
    sp.bsdf = materials.At(static_cast<size_t>(p.materialId[k]));
    LightSample y;
    y.position = Vec3(p.lightPosition[0][k], p.lightPosition[1][k], p.lightPosition[2][k]);
    y.normal = Vec3(p.lightNormal[0][k], p.lightNormal[1][k], p.lightNormal[2][k]);
    y.radiance = Vec3(p.radiance[0][k], p.radiance[1][k], p.radiance[2][k]);
    const Vec3 f = UnshadowedContribution(sp, y);
    out.target[k] = CanonicalNaN(TargetFunction(f));
    if (rgb)
      for (int c = 0; c < 3; ++c) out.contribution[c][k] = CanonicalNaN(f[c]);
  }
}

void EvaluateTargets(const TargetPairs& pairs, const BsdfSoa& materials, const TargetResults& out) {
  if (UseScalarTwins()) return EvaluateTargetsScalar(pairs, materials, out);
  HWY_DYNAMIC_DISPATCH(TargetKernel)(pairs, materials, out);
}

const char* TargetKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(TargetKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
