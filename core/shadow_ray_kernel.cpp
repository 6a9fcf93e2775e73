// Highway kernel, scalar twin and dispatcher of the shadow-ray setup kernel (core/shadow_ray_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): each lane computes core/shadow_ray.h ShadowRaySetup's expression tree term for
// term (core/shadow_ray-inl.h ShadowRaySetupV). NaN results are the one thing the source cannot pin down; both
// sides canonicalise them.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/shadow_ray_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <cmath>
#include <limits>

#include "core/shading-inl.h"
#include "core/shadow_ray-inl.h"
#include "core/shadow_ray.h"
#include "core/shadow_ray_kernel.h"
#include "core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace {

// Input fields in the order x, ng, y, ny (x y z each), then the two error scales; output fields org, dir, tmax:
// flat, so that the full packets and the padded tail address them alike.
constexpr int kInFields = 14;
constexpr int kOutFields = 7;

void InFields(const ShadowRayInputs& in, const float* (&f)[kInFields]) {
  for (int c = 0; c < 3; ++c) {
    f[c] = in.position[c];
    f[3 + c] = in.geometricNormal[c];
    f[6 + c] = in.lightPosition[c];
    f[9 + c] = in.lightNormal[c];
  }
  f[12] = in.errorScale;
  f[13] = in.lightErrorScale;
}

void OutFields(const ShadowRayOutputs& out, float* (&f)[kOutFields]) {
  for (int c = 0; c < 3; ++c) {
    f[c] = out.org[c];
    f[3 + c] = out.dir[c];
  }
  f[6] = out.tmax;
}

// Queries [k, k + Lanes) of the fields.
HWY_INLINE void ShadowRayPacket(const float* const (&in)[kInFields], float* const (&out)[kOutFields], size_t k) {
  const DF df;
  VF x[3], ng[3], y[3], ny[3];
  for (int c = 0; c < 3; ++c) {
    x[c] = hn::LoadU(df, in[c] + k);
    ng[c] = hn::LoadU(df, in[3 + c] + k);
    y[c] = hn::LoadU(df, in[6 + c] + k);
    ny[c] = hn::LoadU(df, in[9 + c] + k);
  }
  const VF errorScale = hn::LoadU(df, in[12] + k);
  const VF lightErrorScale = hn::LoadU(df, in[13] + k);

  VF org[3], dir[3], length;
  ShadowRaySetupV(x, ng, errorScale, y, ny, lightErrorScale, org, dir, length);

  for (int c = 0; c < 3; ++c) {
    hn::StoreU(CanonicalNaNV(org[c]), df, out[c] + k);
    hn::StoreU(CanonicalNaNV(dir[c]), df, out[3 + c] + k);
  }
  hn::StoreU(CanonicalNaNV(length), df, out[6] + k);
}

}  // namespace

void ShadowRayKernel(const ShadowRayInputs& inputs, const ShadowRayOutputs& outputs) {
  const DF df;
  const size_t N = hn::Lanes(df);
  const float* in[kInFields];
  float* out[kOutFields];
  InFields(inputs, in);
  OutFields(outputs, out);

  size_t k = 0;
  for (; k + N <= inputs.count; k += N) ShadowRayPacket(in, out, k);
  if (k == inputs.count) return;

  // Tail: a full packet would read and write past the caller's arrays, so run one on a padded copy. The padding
  // lanes are zeros (their rays come out NaN, harmlessly) and their results are dropped.
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = inputs.count - k;
  HWY_ALIGN float inPad[kInFields][kMax] = {};
  HWY_ALIGN float outPad[kOutFields][kMax];
  const float* padIn[kInFields];
  float* padOut[kOutFields];
  for (int f = 0; f < kInFields; ++f) {
    for (size_t l = 0; l < rest; ++l) inPad[f][l] = in[f][k + l];
    padIn[f] = inPad[f];
  }
  for (int f = 0; f < kOutFields; ++f) padOut[f] = outPad[f];
  ShadowRayPacket(padIn, padOut, 0);
  for (int f = 0; f < kOutFields; ++f)
    for (size_t l = 0; l < rest; ++l) out[f][k + l] = outPad[f][l];
}

const char* ShadowRayKernelTargetName() { return hwy::TargetName(HWY_TARGET); }

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(ShadowRayKernel);
HWY_EXPORT(ShadowRayKernelTargetName);

void SetupShadowRaysScalar(const ShadowRayInputs& in, const ShadowRayOutputs& out) {
  for (size_t k = 0; k < in.count; ++k) {
    const ShadowRaySegment r =
        ShadowRaySetup(Vec3(in.position[0][k], in.position[1][k], in.position[2][k]),
                       Vec3(in.geometricNormal[0][k], in.geometricNormal[1][k], in.geometricNormal[2][k]),
                       in.errorScale[k], Vec3(in.lightPosition[0][k], in.lightPosition[1][k], in.lightPosition[2][k]),
                       Vec3(in.lightNormal[0][k], in.lightNormal[1][k], in.lightNormal[2][k]), in.lightErrorScale[k]);
    for (int c = 0; c < 3; ++c) {
      out.org[c][k] = CanonicalNaN(r.org[c]);
      out.dir[c][k] = CanonicalNaN(r.dir[c]);
    }
    out.tmax[k] = CanonicalNaN(r.tmax);
  }
}

void SetupShadowRays(const ShadowRayInputs& in, const ShadowRayOutputs& out) {
  if (UseScalarTwins()) return SetupShadowRaysScalar(in, out);
  HWY_DYNAMIC_DISPATCH(ShadowRayKernel)(in, out);
}

const char* ShadowRayKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(ShadowRayKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
