// Spawning rays off surfaces (DESIGN §4 "Visibility segments are spawned robustly at both ends"): the scalar
// form, which the passes, the reference and core/shadow_ray_kernel.cpp's SIMD twin all use, so the ray a pass
// traces one at a time and the ray the batch kernel builds are the same bits. Core has no ray type of its own
// (Embree and sim's ShadowRay stay in sim/), hence ShadowRaySegment.
//
// The rule is pbrt-v4's error-bounded spawn (Pharr, Jakob, Humphreys, "Physically Based Rendering" 4th ed.,
// §6.8.6 "Robust Spawned Ray Origins", Interaction::SpawnRayTo): a computed point lies within a bound e of the
// true surface in each coordinate, so moving it e·‖n‖₁ along the geometric normal puts it strictly on the side
// the ray leaves towards; a segment between two surfaces is offset at BOTH ends, and its direction is taken from
// the offset origin to the offset end, so neither end can cross its own surface however grazing the ray.
//
// Embree is not pbrt's intersector: it translates the triangle's vertices to the ray origin, and (through its
// rcp-based division) computes t to a few ulps, so the bound here covers its arithmetic too, with margin:
// - a point's error scale is the largest coordinate magnitude its float value depends on: its triangle's world
//   vertices (and, for an instanced object, the instance translation and the transform's anisotropy; see
//   sim/scene/embree_scene.cpp). Every float operation on such values errs by at most u·scale, u = 2^-24;
// - at the far end the ray's own length adds to the scale: Embree translates the emitter's vertices to the ray
//   origin, so their rounding grows with the distance between the two ends;
// - kSpawnErrorUlps unit roundoffs of that scale: a few operations' worth (the point's own rounding, Embree's
//   translation, cross products and t), times a margin of at least 2. tests/sim/scene/embree_scene_test.cpp traces
//   spawned rays against the surfaces they leave and aim at over a grid of scales, distances from the origin,
//   tilts and grazing angles; every self-hit vanishes from a quarter of this offset on.
// The offset is a bound on float error, not a tuned length: 9.5e-7 of the coordinates' magnitude (5 µm for a
// scene within 5 m of the origin, 1 mm at 1 km, where float spacing itself is 61 µm).
#pragma once

#include <algorithm>
#include <cmath>

#include "core/math.h"

namespace restir {

// Unit roundoff of IEEE single precision: a correctly rounded operation's relative error is at most this.
inline constexpr float kUnitRoundoff = 0x1p-24f;
// Unit roundoffs of a point's error scale that a spawn offset spans (see the file comment).
inline constexpr float kSpawnErrorUlps = 16.0f;
inline constexpr float kSpawnRelativeOffset = kSpawnErrorUlps * kUnitRoundoff;

// An error of at most e in every coordinate moves a point at most e·‖n‖₁ along a unit n (pbrt-v4's
// dot(Abs(n), pError) with an isotropic bound).
inline float NormL1(const Vec3& n) { return (std::fabs(n.x) + std::fabs(n.y)) + std::fabs(n.z); }

// Moves p off its surface along the geometric normal, to the side `towards` points to, by the spawn offset of a
// point whose coordinates have error scale `errorScale` (pbrt-v4 OffsetRayOrigin).
//
// core/shadow_ray-inl.h repeats this expression lane by lane; changing it here changes the kernel's twin,
// and the kernel tests then demand the same change there.
inline Vec3 OffsetRayOrigin(const Vec3& p, const Vec3& geometricNormal, float errorScale, const Vec3& towards) {
  const float offset = (kSpawnRelativeOffset * errorScale) * NormL1(geometricNormal);
  const float side = glm::dot(geometricNormal, towards) >= 0.0f ? 1.0f : -1.0f;
  return p + (side * offset) * geometricNormal;
}

// A shadow ray as plain vectors: from org along dir (unit) up to tmax.
struct ShadowRaySegment {
  Vec3 org;
  Vec3 dir;
  float tmax = 0.0f;
};

// The visibility segment between a receiver x (geometric normal ng, error scale ex) and a light point y (the
// emitter's normal ny, error scale ey): the origin offset off the receiver towards y, the end offset off the
// emitter towards the origin (its scale grown by the segment's length), the direction from the offset origin to
// the offset end, tmax the distance between them. The target p̂ is evaluated on x and y themselves; the segment
// tests the visibility of exactly that pair, the ends displaced by float error only.
inline ShadowRaySegment ShadowRaySetup(const Vec3& position, const Vec3& geometricNormal, float errorScale,
                                       const Vec3& lightPosition, const Vec3& lightNormal, float lightErrorScale) {
  ShadowRaySegment ray;
  ray.org = OffsetRayOrigin(position, geometricNormal, errorScale, lightPosition - position);
  const Vec3 back = ray.org - lightPosition;
  const Vec3 end = OffsetRayOrigin(lightPosition, lightNormal, lightErrorScale + glm::length(back), back);
  const Vec3 d = end - ray.org;
  const float length = glm::length(d);
  ray.dir = d / length;
  ray.tmax = length;
  return ray;
}

}  // namespace restir
