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
  float cosY = 0;      // the emitter's cosine -n_y.wi (or its plane form, ConnectToLightOnPlane); set where d > 0
};

// Below this distance a light point is treated as touching the receiver and contributes nothing: G would blow
// up as 1/d^2 while the set of such points has vanishing measure (documented guard, DESIGN §10).
inline constexpr float kMinLightDistance = 1e-6f;

namespace shading_detail {
// ConnectToLight's stages: the segment (direction, distance; false where y touches x), then the geometry term
// from the emitter's cosine.
inline bool LightSegment(const ShadingPoint& sp, const Vec3& lightPosition, LightPath& p, float& d2) {
  const Vec3 d = lightPosition - sp.position;
  d2 = glm::dot(d, d);
  p.distance = std::sqrt(d2);
  if (!(p.distance > kMinLightDistance)) return false;
  p.wi = d / p.distance;
  return true;
}
inline void LightGeometry(const ShadingPoint& sp, float d2, float cosY, LightPath& p) {
  p.cosY = cosY;
  const float cosX = glm::dot(sp.shadingNormal, p.wi);
  if (cosX <= 0.0f || cosY <= 0.0f || glm::dot(sp.geometricNormal, p.wi) <= 0.0f) return;
  p.geometry = cosX * cosY / d2;
}
}  // namespace shading_detail

inline LightPath ConnectToLight(const ShadingPoint& sp, const Vec3& lightPosition, const Vec3& lightNormal) {
  LightPath p;
  float d2;
  if (!shading_detail::LightSegment(sp, lightPosition, p, d2)) return p;
  shading_detail::LightGeometry(sp, d2, -glm::dot(lightNormal, p.wi), p);
  return p;
}

// ConnectToLight to a point y sampled on an emitter's triangle, with the emitter's cosine taken from its plane:
// cos θy = n_y · (x − p0) / d, p0 a vertex (exact), which equals n_y · (x − y) / d for y on the plane. A y computed in
// float lies up to half a float spacing off the plane (30 µm at 1000 m from the origin, 0.5 mm at 10 km), so
// n_y · (x − y) misjudges a receiver that close to the plane, even which side it is on (a receiver behind the
// emitter got light); x − p0 is exact where x and p0 are within a factor 2 of each other (Sterbenz), so the
// plane form's side and size keep their digits at any distance from the origin. The reference's light sampling
// uses it (core/light_draw_kernel.h, sim/reference/reference_samples.cpp).
inline LightPath ConnectToLightOnPlane(const ShadingPoint& sp, const Vec3& lightPosition, const Vec3& lightNormal,
                                       const Vec3& lightVertex) {
  LightPath p;
  float d2;
  if (!shading_detail::LightSegment(sp, lightPosition, p, d2)) return p;
  shading_detail::LightGeometry(sp, d2, glm::dot(lightNormal, sp.position - lightVertex) / p.distance, p);
  return p;
}

// L_e f_r(x, wi, wo) G along a connected path: 0 where its geometry is.
inline Vec3 ContributionAlong(const ShadingPoint& sp, const Vec3& radiance, const LightPath& path) {
  if (path.geometry <= 0.0f) return Vec3(0.0f);
  return radiance * EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi) * path.geometry;
}

// Unshadowed contribution L_e(y) f_r(x, wi, wo) G(x, y) (DESIGN §4 integrand without V), RGB.
inline Vec3 UnshadowedContribution(const ShadingPoint& sp, const LightSample& y) {
  return ContributionAlong(sp, y.radiance, ConnectToLight(sp, y.position, y.normal));
}

// Target function p̂(y) = luminance(L_e f_r G): unshadowed (seed 003 §1, seed 000 Table 1).
inline float TargetFunction(const Vec3& unshadowedContribution) { return Luminance(unshadowedContribution); }

}  // namespace restir
