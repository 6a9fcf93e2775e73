// The integrand and the target function of DESIGN §4, for one receiver and one light sample.
#pragma once

#include "core/bsdf.h"
#include "core/light.h"
#include "core/math.h"

namespace restir {

// A primary-hit receiver x (DESIGN §4 notation).
struct ShadingPoint {
  Vec3 position;         // x
  Vec3 geometricNormal;  // facing the viewer; a light below it cannot reach x
  Vec3 shadingNormal;    // n, facing the viewer
  Vec3 wo;               // unit direction from x towards the viewer
  Bsdf bsdf;             // reflectance at x
  float errorScale = 0;  // x's error scale, for spawning rays off it (core/shadow_ray.h)
};

// Geometry of the segment x -> y: unit direction, distance and squared distance.
struct LightPath {
  Vec3 wi;             // normalize(p_y - x)
  float distance = 0;  // d
  float geometry = 0;  // G(x, y) = max(0, n.wi) max(0, -n_y.wi) / d^2, zero when y is behind the geometric normal
};

// Below this distance a light point is treated as touching the receiver and contributes nothing: G would blow
// up as 1/d^2 while the set of such points has vanishing measure (documented guard, DESIGN §10).
inline constexpr float kMinLightDistance = 1e-6f;

inline LightPath ConnectToLight(const ShadingPoint& sp, const Vec3& lightPosition, const Vec3& lightNormal) {
  LightPath p;
  const Vec3 d = lightPosition - sp.position;
  const float d2 = glm::dot(d, d);
  p.distance = std::sqrt(d2);
  if (!(p.distance > kMinLightDistance)) return p;
  p.wi = d / p.distance;
  const float cosX = glm::dot(sp.shadingNormal, p.wi);
  const float cosY = -glm::dot(lightNormal, p.wi);
  if (cosX <= 0.0f || cosY <= 0.0f || glm::dot(sp.geometricNormal, p.wi) <= 0.0f) return p;
  p.geometry = cosX * cosY / d2;
  return p;
}

// Unshadowed contribution L_e(y) f_r(x, wi, wo) G(x, y) (DESIGN §4 integrand without V), RGB.
inline Vec3 UnshadowedContribution(const ShadingPoint& sp, const LightSample& y) {
  const LightPath path = ConnectToLight(sp, y.position, y.normal);
  if (path.geometry <= 0.0f) return Vec3(0.0f);
  return y.radiance * EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi) * path.geometry;
}

// Target function p̂(y) = luminance(L_e f_r G): unshadowed (seed 003 §1, seed 000 Table 1).
inline float TargetFunction(const Vec3& unshadowedContribution) { return Luminance(unshadowedContribution); }

}  // namespace restir
