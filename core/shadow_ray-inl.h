// Per-target Highway form of core/shadow_ray.h ShadowRaySetup, shared by the kernels that set up shadow rays
// (core/shadow_ray_kernel.cpp, core/light_draw_kernel.cpp) so that the rule has one SIMD form beside its one
// scalar form.
//
// Include after "hwy/foreach_target.h", "hwy/highway.h" and core/shading-inl.h, outside any namespace: like
// every Highway -inl header it is compiled once per target and opens restir::HWY_NAMESPACE itself.
//
// Bit-exactness (DESIGN §3): each lane computes ShadowRaySetup's expression tree term for term: glm::length =
// sqrt((x x + y y) + z z), vec3 / s divides each component, NormL1 = (|x| + |y|) + |z|, the offset is
// (kSpawnRelativeOffset scale) NormL1 with the product taken in that order, and the side test is `>= 0`
// (false for NaN, so a NaN direction offsets against the normal). No MulAdd, no approximate square roots or
// reciprocals.

#include "core/shading-inl.h"
#include "core/shadow_ray.h"

// Highway's per-target include guard: the body is compiled once for each target foreach_target.h toggles.
#if defined(RESTIR_CORE_SHADOW_RAY_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_SHADOW_RAY_INL_H_
#undef RESTIR_CORE_SHADOW_RAY_INL_H_
#else
#define RESTIR_CORE_SHADOW_RAY_INL_H_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {

// OffsetRayOrigin (core/shadow_ray.h): p moved off its surface along n, to the side `towards` points to.
HWY_INLINE void OffsetRayOriginV(const VF (&p)[3], const VF (&n)[3], VF errorScale, const VF (&towards)[3],
                                 VF (&out)[3]) {
  const DF df;
  const VF norm1 = hn::Add(hn::Add(hn::Abs(n[0]), hn::Abs(n[1])), hn::Abs(n[2]));
  const VF offset = hn::Mul(hn::Mul(hn::Set(df, kSpawnRelativeOffset), errorScale), norm1);
  const VF side =
      hn::IfThenElse(hn::Ge(Dot(n, towards), hn::Zero(df)), hn::Set(df, 1.0f), hn::Set(df, -1.0f));
  const VF signedOffset = hn::Mul(side, offset);
  for (int c = 0; c < 3; ++c) out[c] = hn::Add(p[c], hn::Mul(signedOffset, n[c]));
}

// ShadowRaySetup (core/shadow_ray.h): the segment from receiver x (geometric normal ng, error scale es) to
// light point y (emitter normal ny, error scale les), as origin, unit direction and length. Not
// NaN-canonicalised.
HWY_INLINE void ShadowRaySetupV(const VF (&x)[3], const VF (&ng)[3], VF errorScale, const VF (&y)[3],
                                const VF (&ny)[3], VF lightErrorScale, VF (&org)[3], VF (&dir)[3], VF& tmax) {
  VF toLight[3], back[3], end[3], d[3];
  for (int c = 0; c < 3; ++c) toLight[c] = hn::Sub(y[c], x[c]);
  OffsetRayOriginV(x, ng, errorScale, toLight, org);
  for (int c = 0; c < 3; ++c) back[c] = hn::Sub(org[c], y[c]);
  OffsetRayOriginV(y, ny, hn::Add(lightErrorScale, hn::Sqrt(Dot(back, back))), back, end);
  for (int c = 0; c < 3; ++c) d[c] = hn::Sub(end[c], org[c]);
  tmax = hn::Sqrt(Dot(d, d));
  for (int c = 0; c < 3; ++c) dir[c] = hn::Div(d[c], tmax);
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_SHADOW_RAY_INL_H_ toggle
