// The shadow-ray segment from a receiver to a light point (DESIGN §4 visibility V(x, y)): the scalar form, which
// sim/pipeline.cpp MakeShadowRay and core/shadow_ray_kernel.cpp's twin both call, so that the ray a pass traces
// one at a time and the ray the batch kernel builds are the same bits. Core has no ray type of its own (Embree
// and sim's ShadowRay stay in sim/), hence ShadowRaySegment.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/math.h"

namespace restir {

// Offsets a ray origin off a surface along its geometric normal, on the side `dir` leaves towards, so a
// secondary ray does not re-hit the surface it starts on (scale-aware epsilon).
//
// core/shadow_ray_kernel.cpp repeats this expression lane by lane; changing it here changes the kernel's twin,
// and the kernel tests then demand the same change there.
inline Vec3 OffsetRayOrigin(const Vec3& p, const Vec3& geometricNormal, const Vec3& dir) {
  // Float error in a hit position grows with its magnitude, so the offset does too.
  const float scale = std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z)));
  const float eps = 1e-4f * (1.0f + scale);
  const float side = glm::dot(geometricNormal, dir) >= 0.0f ? 1.0f : -1.0f;
  return p + (side * eps) * geometricNormal;
}

// A shadow ray as plain vectors: from org along dir (unit) up to tmax.
struct ShadowRaySegment {
  Vec3 org;
  Vec3 dir;
  float tmax = 0.0f;
};

// The shadow ray from a receiver x (position, geometric normal ng) to a light point y. dir is taken from x, not
// from the offset origin, so it is the direction the receiver's target was evaluated along; tmax is measured
// from the offset origin and stops a relative 1e-3 short of y, so the emitter triangle y lies on (or a surface
// y sits on) never counts as an occluder, at any scene scale.
inline ShadowRaySegment ShadowRaySetup(const Vec3& position, const Vec3& geometricNormal,
                                       const Vec3& lightPosition) {
  const Vec3 toLight = lightPosition - position;
  const float d = glm::length(toLight);
  ShadowRaySegment ray;
  ray.dir = toLight / d;
  ray.org = OffsetRayOrigin(position, geometricNormal, ray.dir);
  ray.tmax = glm::length(lightPosition - ray.org) * (1.0f - 1e-3f);
  return ray;
}

}  // namespace restir
